#pragma once
// A smooth synthetic WMS and World Wind tile server for FakeUpstream (tests of whole polar rows,
// issue 29): every pixel's colour is a smooth function of its centre's latitude and longitude,
// so an image of any box at any size, or a row composed of tiles, can be compared pixel for pixel.
// WMS 1.3.0 GetMap in EPSG:4326 (BBOX south,west,north,east) or World Wind's T/L/X/Y on a grid
// of `deltaDeg` level-zero tiles of `tilePx` pixels; JPEG.

#include "FakeUpstream.hpp"

#include <tellus/proxy/ImageCodec.hpp>

#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <numbers>
#include <string>
#include <vector>

namespace tellus::test {

/** The colour at (lat, lon) in degrees: red and green turn with longitude, blue with latitude. */
inline std::array<std::uint8_t, 3> syntheticColour(double lat, double lon) {
  const double a = lon * std::numbers::pi / 180.0;
  return {static_cast<std::uint8_t>(std::lround(128.0 + 90.0 * std::sin(a))),
          static_cast<std::uint8_t>(std::lround(128.0 + 90.0 * std::cos(a))),
          static_cast<std::uint8_t>(std::lround(40.0 + (lat + 90.0) * 170.0 / 180.0))};
}

/** A JPEG of the box (degrees) at width x height pixels. */
inline std::string
syntheticJpeg(double west, double south, double east, double north, int width, int height) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                               3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double lat = north - (y + 0.5) * (north - south) / height;
      const double lon = west + (x + 0.5) * (east - west) / width;
      const auto c = syntheticColour(lat, lon);
      const auto i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                      static_cast<std::size_t>(x)) *
                     3;
      px[i] = c[0];
      px[i + 1] = c[1];
      px[i + 2] = c[2];
    }
  const auto bytes = *encodeImage("image/jpeg", width, height, 3, px.data());
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

/** The query's parameters (names upper-cased; values as sent). */
inline std::map<std::string, std::string> queryParams(const std::string& target) {
  std::map<std::string, std::string> out;
  const auto q = target.find('?');
  if (q == std::string::npos) return out;
  std::size_t at = q + 1;
  while (at <= target.size()) {
    auto end = target.find('&', at);
    if (end == std::string::npos) end = target.size();
    const std::string kv = target.substr(at, end - at);
    const auto eq = kv.find('=');
    std::string k = kv.substr(0, eq);
    for (char& ch : k)
      ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    out[k] = eq == std::string::npos ? "" : kv.substr(eq + 1);
    at = end + 1;
  }
  return out;
}

/** The reply of the synthetic server to a GetMap or a World Wind tile request. */
inline FakeReply syntheticReply(const FakeRequest& req, double deltaDeg = 36.0, int tilePx = 256) {
  const auto p = queryParams(req.target);
  if (p.contains("BBOX")) {
    double b[4] = {};
    const char* s = p.at("BBOX").c_str();
    for (double& v : b) {
      char* end = nullptr;
      v = std::strtod(s, &end);
      s = *end == ',' ? end + 1 : end;
    }
    // WMS 1.3.0 EPSG:4326: south, west, north, east.
    return FakeReply::ok(
        syntheticJpeg(b[1], b[0], b[3], b[2], std::stoi(p.at("WIDTH")), std::stoi(p.at("HEIGHT"))),
        "image/jpeg");
  }
  const int level = std::stoi(p.at("L"));
  const double d = std::ldexp(deltaDeg, -level);
  const double west = -180.0 + std::stod(p.at("X")) * d, south = -90.0 + std::stod(p.at("Y")) * d;
  return FakeReply::ok(syntheticJpeg(west, south, west + d, south + d, tilePx, tilePx),
                       "image/jpeg");
}

} // namespace tellus::test
