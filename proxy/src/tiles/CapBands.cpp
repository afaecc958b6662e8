// A polar cap fetched in bands (CapBands.hpp).

#include "tiles/CapBands.hpp"

#include <tellus/proxy/ImageCodec.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus {

std::vector<CapBand> capBands(const Sector& row, int width, int height) {
  const bool north = row.north == 90.0 && row.south > -90.0;
  const bool south = row.south == -90.0 && row.north < 90.0;
  const double h = row.north - row.south; // the rim's co-latitude, degrees
  const int n = std::clamp(height / kMinCapBandRows, 1, kCapBands);
  if ((!north && !south) || h <= 0.0 || h > 90.0 || n == 1 || width < 1)
    return {CapBand{row, width, height, 0}};
  const double toRad = std::numbers::pi / 180.0;
  const double sinRim = std::sin(h * toRad);
  // Row r of the image (from the north) at its edge's latitude; the rim and the pole exact.
  const auto latAt = [&](int r) {
    if (r == 0) return row.north;
    if (r == height) return row.south;
    return north ? 90.0 - h * r / height : -90.0 + h * (height - r) / height;
  };
  std::vector<CapBand> bands;
  bands.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    CapBand b;
    b.row0 = static_cast<int>(std::lround(static_cast<double>(i) * height / n));
    const int row1 = static_cast<int>(std::lround(static_cast<double>(i + 1) * height / n));
    b.height = row1 - b.row0;
    b.box = Sector{-180.0, latAt(row1), 180.0, latAt(b.row0)};
    // The band's equatorward parallel: its last row in a north cap, its first in a south one.
    const double colat = 90.0 - std::fabs(north ? b.box.south : b.box.north);
    const double w = std::ceil(width * std::sin(colat * toRad) / sinRim - 1e-9);
    b.width = std::clamp(static_cast<int>(w), 1, width);
    bands.push_back(b);
  }
  return bands;
}

std::expected<std::vector<std::byte>, std::string>
composeBands(std::span<const CapBand> bands,
             std::span<const std::vector<std::byte>> images,
             int width,
             int height,
             std::string_view mimeType,
             bool wrap) {
  if (bands.size() != images.size()) return std::unexpected("a band is missing");
  std::vector<DecodedImage> decoded;
  decoded.reserve(bands.size());
  bool alpha = false;
  for (std::size_t i = 0; i < bands.size(); ++i) {
    auto img = decodeImagery(images[i], mimeType, bands[i].width, bands[i].height);
    if (!img) return std::unexpected("band " + std::to_string(i) + ": " + img.error());
    alpha = alpha || img->channels == 4;
    decoded.push_back(std::move(*img));
  }
  const std::size_t out = mimeType == "image/png" && alpha ? 4 : 3;
  const auto W = static_cast<std::size_t>(width);
  std::vector<std::uint8_t> px(W * static_cast<std::size_t>(height) *
                               static_cast<std::size_t>(out));
  struct Column {
    std::size_t a = 0, c = 0; ///< the two source texels' offsets in a row
    double f = 0.0;           ///< the weight of c
  };
  std::vector<Column> cols(W);
  for (std::size_t i = 0; i < bands.size(); ++i) {
    const CapBand& b = bands[i];
    const DecodedImage& img = decoded[i];
    const auto w = static_cast<std::int64_t>(img.width);
    const auto ch = static_cast<std::size_t>(img.channels);
    // Each output column's centre in the band's columns, the same on every row: a whole parallel
    // wraps around, a box's edge texels hold.
    const auto offset = [&](std::int64_t at) {
      return static_cast<std::size_t>(wrap ? (at % w + w) % w
                                           : std::clamp<std::int64_t>(at, 0, w - 1)) *
             ch;
    };
    for (std::size_t x = 0; x < W; ++x) {
      const double u = (static_cast<double>(x) + 0.5) * static_cast<double>(w) / width - 0.5;
      const double uf = std::floor(u);
      const auto i0 = static_cast<std::int64_t>(uf);
      cols[x] = Column{offset(i0), offset(i0 + 1), u - uf};
    }
    for (int y = 0; y < b.height; ++y) {
      const std::uint8_t* src =
          img.pixels.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w) * ch;
      std::uint8_t* dst = px.data() + static_cast<std::size_t>(b.row0 + y) * W * out;
      for (std::size_t x = 0; x < W; ++x) {
        const auto [a, c, f] = cols[x];
        const double wa = ch == 4 ? (1.0 - f) * src[a + 3] / 255.0 : 1.0 - f;
        const double wc = ch == 4 ? f * src[c + 3] / 255.0 : f;
        const double sum = wa + wc;
        for (std::size_t k = 0; k < 3; ++k) {
          const double v = sum > 0.0 ? (wa * src[a + k] + wc * src[c + k]) / sum : 0.0;
          dst[x * out + k] = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
        }
        if (out == 4) {
          const double al =
              ch == 4 ? (1.0 - f) * src[a + 3] + f * src[c + 3] : 255.0; // an opaque band
          dst[x * out + 3] = static_cast<std::uint8_t>(std::lround(std::clamp(al, 0.0, 255.0)));
        }
      }
    }
  }
  return encodeImage(mimeType, width, height, static_cast<int>(out), px.data(), /*tile=*/true);
}

} // namespace tellus
