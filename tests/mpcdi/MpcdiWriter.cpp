#include "MpcdiWriter.hpp"

#include <tellus/codec/Png.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <zip.h>

namespace tellus::mpcdi::test {

std::vector<planet::Channel> fiveChannelDome(int s) {
  std::vector<planet::Channel> out;
  for (const auto& [name, az] : {std::pair{"north", 0.0},
                                 std::pair{"east", 90.0},
                                 std::pair{"south", 180.0},
                                 std::pair{"west", 270.0}}) {
    planet::Channel c;
    c.name = name;
    c.azimuthDeg = az;
    c.elevationDeg = 20;
    c.hfovDeg = 110;
    c.vfovDeg = 90;
    c.width = 100 * s;
    c.height = 70 * s;
    out.push_back(c);
  }
  planet::Channel top;
  top.name = "zenith";
  top.elevationDeg = 90;
  top.hfovDeg = top.vfovDeg = 100;
  top.width = top.height = 70 * s;
  out.push_back(top);
  return out;
}

std::string pfm(int width, int height, const std::vector<float>& xyz) {
  std::string out = "PF\n" + std::to_string(width) + " " + std::to_string(height) + "\n-1.0\n";
  const std::size_t row = static_cast<std::size_t>(width) * 3;
  for (int y = height - 1; y >= 0; --y)
    out.append(reinterpret_cast<const char*>(xyz.data() + row * static_cast<std::size_t>(y)),
               row * sizeof(float));
  return out;
}

std::vector<float> identityWarp3d(const planet::Channel& c, int width, int height) {
  std::vector<float> xyz;
  for (int j = 0; j < height; ++j)
    for (int i = 0; i < width; ++i) {
      const glm::dvec3 d = planet::channelPixelDirection(
          c, {(i + 0.5) / width * c.width, (j + 0.5) / height * c.height});
      // dome (x, y, z) = (-right, forward, -up); with no coordinateFrame the warp's x is
      // MPCDI's right, y its up and -z its forward (OpenGL's eye axes)
      for (const double v : {-d.x, -d.z, -d.y})
        xyz.push_back(static_cast<float>(10.0 * v));
    }
  return xyz;
}

std::string regionXml(const planet::Channel& c) {
  auto n = [](double v) { return std::to_string(v); };
  return "<region id=\"" + c.name + "\" x=\"0\" y=\"0\" xsize=\"1\" ysize=\"1\" xResolution=\"" +
         std::to_string(c.width) + "\" yResolution=\"" + std::to_string(c.height) +
         "\"><frustum><yaw>" + n(-c.azimuthDeg) + "</yaw><pitch>" + n(c.elevationDeg) +
         "</pitch><roll>" + n(c.rollDeg) + "</roll><rightAngle>" + n(c.hfovDeg / 2) +
         "</rightAngle><leftAngle>" + n(-c.hfovDeg / 2) + "</leftAngle><upAngle>" +
         n(c.vfovDeg / 2) + "</upAngle><downAngle>" + n(-c.vfovDeg / 2) +
         "</downAngle></frustum></region>\n";
}

std::string filesetXml(const std::string& region,
                       const std::string& warpPath,
                       const std::string& alphaPath,
                       double gamma) {
  std::string s = "<fileset region=\"" + region + "\">";
  if (!warpPath.empty())
    s += "<geometryWarpFile><path>" + warpPath +
         "</path><geometricUnit>m</geometricUnit><originOf3DData>idealEyePoint</originOf3DData>"
         "<interpolation>linear</interpolation></geometryWarpFile>";
  if (!alphaPath.empty())
    s += "<alphaMap><path>" + alphaPath + "</path><componentDepth>1</componentDepth><bitDepth>8" +
         "</bitDepth><gammaEmbedded>" + std::to_string(gamma) + "</gammaEmbedded></alphaMap>";
  return s + "</fileset>\n";
}

std::string
documentXml(const std::string& profile, const std::string& regions, const std::string& filesets) {
  return "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<MPCDI profile=\"" + profile +
         "\" geometry=\"1\" version=\"2.0\">\n<display><buffer id=\"dome\" xResolution=\"1\" "
         "yResolution=\"1\">\n" +
         regions + "</buffer></display>\n<files>\n" + filesets + "</files>\n</MPCDI>\n";
}

void writeZip(const std::filesystem::path& file,
              const std::map<std::string, std::string>& entries) {
  int err = 0;
  zip_t* z = zip_open(file.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  if (z == nullptr) throw std::runtime_error("zip_open " + file.string());
  for (const auto& [name, bytes] : entries) {
    zip_source_t* src = zip_source_buffer(z, bytes.data(), bytes.size(), 0);
    if (src == nullptr || zip_file_add(z, name.c_str(), src, ZIP_FL_OVERWRITE) < 0)
      throw std::runtime_error("zip_file_add " + name);
  }
  if (zip_close(z) != 0) throw std::runtime_error("zip_close " + file.string());
}

std::map<std::string, std::string> domeEntries(int scale, int texels, bool alpha) {
  std::map<std::string, std::string> e;
  std::string regions, sets;
  for (const planet::Channel& c : fiveChannelDome(scale)) {
    const int w = texels, h = std::max(2, static_cast<int>(std::lround(texels * 0.7)));
    e[c.name + ".pfm"] = pfm(w, h, identityWarp3d(c, w, h));
    regions += regionXml(c);
    std::string alphaPath;
    if (alpha) {
      // A soft edge: 255 inside, falling to 0 over the outer tenth.
      std::vector<std::uint8_t> a(static_cast<std::size_t>(c.width * c.height));
      for (int y = 0; y < c.height; ++y)
        for (int x = 0; x < c.width; ++x) {
          const double ex = std::min(x + 0.5, c.width - x - 0.5) / (0.1 * c.width);
          const double ey = std::min(y + 0.5, c.height - y - 0.5) / (0.1 * c.height);
          a[static_cast<std::size_t>(y * c.width + x)] =
              static_cast<std::uint8_t>(std::lround(255.0 * std::min(1.0, std::min(ex, ey))));
        }
      const auto png = codec::encodePng(c.width, c.height, 1, a.data());
      if (!png) throw std::runtime_error(png.error());
      alphaPath = c.name + "-alpha.png";
      e[alphaPath] = std::string(reinterpret_cast<const char*>(png->data()), png->size());
    }
    sets += filesetXml(c.name, c.name + ".pfm", alphaPath);
  }
  e["mpcdi.xml"] = documentXml("3d", regions, sets);
  return e;
}

} // namespace tellus::mpcdi::test
