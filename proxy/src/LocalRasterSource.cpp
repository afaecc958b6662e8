#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

namespace tellus {

namespace fs = std::filesystem;

fs::path worldFileFor(const fs::path& image) {
  std::string ext = image.extension().string();
  std::vector<std::string> candidates;
  if (ext.size() >= 3) candidates.push_back(std::string(".") + ext[1] + ext.back() + 'w');
  candidates.push_back(".wld");
  for (const auto& c : candidates) {
    fs::path p = image;
    p.replace_extension(c);
    if (fs::exists(p)) return p;
  }
  fs::path p = image;
  p.replace_extension(candidates.front());
  return p;
}

std::expected<RasterGeoref, std::string> readWorldFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::unexpected("cannot read world file " + path.string());
  double v[6];
  for (double& x : v) {
    if (!(in >> x) || !std::isfinite(x))
      return std::unexpected("world file " + path.string() + " needs six numbers");
  }
  if (v[1] != 0.0 || v[2] != 0.0)
    return std::unexpected("world file " + path.string() + " is rotated");
  if (!(v[0] > 0.0) || !(v[3] < 0.0)) {
    return std::unexpected("world file " + path.string() + " must have x size > 0 and y size < 0");
  }
  // Lines 5 and 6 give the centre of the upper-left pixel; tellus keeps pixel edges.
  return RasterGeoref{v[4] - v[0] / 2, v[5] - v[3] / 2, v[0], -v[3]};
}

std::expected<LocalRasterSource, std::string> LocalRasterSource::open(const fs::path& image) {
  auto georef = readWorldFile(worldFileFor(image));
  if (!georef) return std::unexpected(georef.error());
  // tellus runs its own workers: OpenImageIO's global pool would only oversubscribe the cores (and
  // it is invisible to ThreadSanitizer). Set once, before the first image is opened.
  static const bool singleThreaded = OIIO::attribute("threads", 1);
  (void)singleThreaded;
  auto in = OIIO::ImageInput::open(image.string());
  if (!in) return std::unexpected("cannot open " + image.string() + ": " + OIIO::geterror());
  in->threads(1);
  const OIIO::ImageSpec& spec = in->spec();
  LocalRasterSource src;
  src.width_ = spec.width;
  src.height_ = spec.height;
  src.channels_ = std::min(spec.nchannels, 4);
  src.georef_ = *georef;
  const auto n = static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
                 static_cast<std::size_t>(src.channels_);
  auto pixels = std::make_shared<std::vector<float>>(n);
  bool ok = false;
  if (spec.format == OIIO::TypeDesc::UINT8) {
    std::vector<unsigned char> raw(n);
    ok = in->read_image(0, 0, 0, src.channels_, OIIO::TypeDesc::UINT8, raw.data());
    std::transform(raw.begin(), raw.end(), pixels->begin(), [](unsigned char c) {
      return static_cast<float>(c);
    });
  } else {
    // Heights and other measurements keep their raw values (no normalisation to 0..1).
    std::vector<double> raw(n);
    ok = in->read_image(0, 0, 0, src.channels_, OIIO::TypeDesc::DOUBLE, raw.data());
    if (spec.format == OIIO::TypeDesc::INT16) {
      for (auto& x : raw)
        x = std::round(x * 32767.0);
    } else if (spec.format == OIIO::TypeDesc::UINT16) {
      for (auto& x : raw)
        x = std::round(x * 65535.0);
    }
    std::transform(
        raw.begin(), raw.end(), pixels->begin(), [](double d) { return static_cast<float>(d); });
  }
  if (!ok) return std::unexpected("cannot read " + image.string() + ": " + in->geterror());
  src.pixels_ = std::move(pixels);
  return src;
}

Sector LocalRasterSource::coverage() const noexcept {
  return Sector{georef_.west,
                georef_.north - georef_.pixelHeightDeg * height_,
                georef_.west + georef_.pixelWidthDeg * width_,
                georef_.north};
}

double LocalRasterSource::sample(double latDeg, double lonDeg, int channel) const noexcept {
  if (!std::isfinite(latDeg) || !std::isfinite(lonDeg) || channel < 0 || channel >= channels_) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const bool wraps = std::abs(georef_.pixelWidthDeg * width_ - 360.0) < 1e-9;
  // Continuous pixel coordinates of the position, relative to pixel centres.
  double x = (lonDeg - georef_.west) / georef_.pixelWidthDeg - 0.5;
  const double y = (georef_.north - latDeg) / georef_.pixelHeightDeg - 0.5;
  if (y < -0.5 - 1e-9 || y > height_ - 0.5 + 1e-9) return std::numeric_limits<double>::quiet_NaN();
  if (!wraps && (x < -0.5 - 1e-9 || x > width_ - 0.5 + 1e-9))
    return std::numeric_limits<double>::quiet_NaN();
  const double yc = std::clamp(y, 0.0, static_cast<double>(height_ - 1));
  const auto y0 = static_cast<int>(std::floor(yc));
  const int y1 = std::min(y0 + 1, height_ - 1);
  const double fy = yc - y0;
  int x0 = 0;
  int x1 = 0;
  double fx = 0.0;
  if (wraps) {
    const double xf = std::floor(x);
    fx = x - xf;
    const auto xi = static_cast<long long>(xf);
    x0 = static_cast<int>(((xi % width_) + width_) % width_);
    x1 = (x0 + 1) % width_;
  } else {
    const double xc = std::clamp(x, 0.0, static_cast<double>(width_ - 1));
    x0 = static_cast<int>(std::floor(xc));
    x1 = std::min(x0 + 1, width_ - 1);
    fx = xc - x0;
  }
  const auto& px = *pixels_;
  auto at = [&](int xx, int yy) {
    return static_cast<double>(px[(static_cast<std::size_t>(yy) * static_cast<std::size_t>(width_) +
                                   static_cast<std::size_t>(xx)) *
                                      static_cast<std::size_t>(channels_) +
                                  static_cast<std::size_t>(channel)]);
  };
  const double top = at(x0, y0) * (1 - fx) + at(x1, y0) * fx;
  const double bottom = at(x0, y1) * (1 - fx) + at(x1, y1) * fx;
  return top * (1 - fy) + bottom * fy;
}

std::expected<std::vector<std::byte>, std::string>
LocalRasterSource::renderTile(const Sector& box,
                              int width,
                              int height,
                              std::string_view mimeType,
                              std::int16_t noData) const {
  if (width <= 0 || height <= 0 || width > 8192 || height > 8192) {
    return std::unexpected("tile size " + std::to_string(width) + "x" + std::to_string(height) +
                           " out of range");
  }
  if (!std::isfinite(box.west) || !std::isfinite(box.east) || !std::isfinite(box.south) ||
      !std::isfinite(box.north) || !(box.north > box.south) || !(box.east > box.west)) {
    return std::unexpected("bad box");
  }
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  const double dx = (box.east - box.west) / width;
  const double dy = (box.north - box.south) / height;
  const bool elevation = mimeType == "application/bil16" || mimeType == "image/tiff";
  if (elevation) {
    std::vector<std::int16_t> heights(w * h);
    for (std::size_t j = 0; j < h; ++j) {
      const double lat = box.north - (static_cast<double>(j) + 0.5) * dy;
      for (std::size_t i = 0; i < w; ++i) {
        const double lon = box.west + (static_cast<double>(i) + 0.5) * dx;
        const double v = sample(lat, lon, 0);
        heights[j * w + i] =
            std::isnan(v) ? noData
                          : static_cast<std::int16_t>(std::clamp(std::round(v), -32767.0, 32767.0));
      }
    }
    return encodeHeights(mimeType, width, height, heights.data());
  }
  const bool png = mimeType == "image/png";
  if (!png && mimeType != "image/jpeg")
    return std::unexpected("unsupported format " + std::string(mimeType));
  const int outChannels = png ? 4 : 3;
  const auto oc = static_cast<std::size_t>(outChannels);
  std::vector<unsigned char> rgba(w * h * oc);
  for (std::size_t j = 0; j < h; ++j) {
    const double lat = box.north - (static_cast<double>(j) + 0.5) * dy;
    for (std::size_t i = 0; i < w; ++i) {
      const double lon = box.west + (static_cast<double>(i) + 0.5) * dx;
      unsigned char* p = &rgba[(j * w + i) * oc];
      const double first = sample(lat, lon, 0);
      const bool inside = !std::isnan(first);
      for (int c = 0; c < 3; ++c) {
        const double v = inside ? sample(lat, lon, std::min(c, channels_ - 1)) : 0.0;
        p[c] = static_cast<unsigned char>(std::clamp(std::round(v), 0.0, 255.0));
      }
      if (png) {
        const double a = (inside && channels_ == 4) ? sample(lat, lon, 3) : (inside ? 255.0 : 0.0);
        p[3] = static_cast<unsigned char>(std::clamp(std::round(a), 0.0, 255.0));
      }
    }
  }
  return encodeImage(mimeType, width, height, outChannels, rgba.data());
}

} // namespace tellus
