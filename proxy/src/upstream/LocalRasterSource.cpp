#include "imaging/ImagingLoader.hpp"

#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <type_traits>
#include <variant>

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

struct LocalRasterSource::Pixels {
  fs::path file;
  std::once_flag once;
  std::atomic<bool> done{false};
  std::string error; ///< set (once) when decoding failed
  std::variant<std::monostate,
               std::vector<std::uint8_t>,
               std::vector<std::int16_t>,
               std::vector<float>>
      samples;
};

namespace {

SampleType sampleTypeOf(std::int32_t fileFormat) noexcept {
  switch (fileFormat) {
  case 1:
    return SampleType::UInt8;
  case 2:
    return SampleType::Int16;
  case 3:
    return SampleType::UInt16;
  case 4:
    return SampleType::Float32;
  default:
    return SampleType::Other;
  }
}

/** Receives read_raster()'s samples in the type the module announces in `info`. */
class SamplesSink final : public imaging::Sink {
public:
  TellusImagingRasterInfo info{};
  std::variant<std::monostate,
               std::vector<std::uint8_t>,
               std::vector<std::int16_t>,
               std::vector<float>>
      samples;

private:
  void* allocate(std::size_t size) override {
    switch (info.sampleType) {
    case TELLUS_IMAGING_UINT8:
      return std::get<1>(samples = std::vector<std::uint8_t>(size)).data();
    case TELLUS_IMAGING_INT16:
      return std::get<2>(samples = std::vector<std::int16_t>(size / 2)).data();
    case TELLUS_IMAGING_FLOAT32:
      return std::get<3>(samples = std::vector<float>(size / 4)).data();
    default:
      return nullptr;
    }
  }
};

/**
 * Bilinear sample of one channel of row-major, north-first samples (NaN outside). A tap that is no
 * data (equal to `noData`, or NaN) is never mixed in: where one of the four is, the sample is the
 * nearest tap that has data (the one of largest weight), NaN when none has (the composer's rule
 * for heights, Compose.cpp's sampleHeight). A `noData` of NaN marks no sample but NaN.
 */
template <class T>
double sampleFrom(const T* px,
                  int width,
                  int height,
                  int channels,
                  const RasterGeoref& g,
                  double latDeg,
                  double lonDeg,
                  int channel,
                  double noData) noexcept {
  if (!std::isfinite(latDeg) || !std::isfinite(lonDeg) || channel < 0 || channel >= channels) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const bool wraps = std::abs(g.pixelWidthDeg * width - 360.0) < 1e-9;
  // Continuous pixel coordinates of the position, relative to pixel centres.
  double x = (lonDeg - g.west) / g.pixelWidthDeg - 0.5;
  const double y = (g.north - latDeg) / g.pixelHeightDeg - 0.5;
  if (y < -0.5 - 1e-9 || y > height - 0.5 + 1e-9) return std::numeric_limits<double>::quiet_NaN();
  if (!wraps && (x < -0.5 - 1e-9 || x > width - 0.5 + 1e-9))
    return std::numeric_limits<double>::quiet_NaN();
  const double yc = std::clamp(y, 0.0, static_cast<double>(height - 1));
  const auto y0 = static_cast<int>(std::floor(yc));
  const int y1 = std::min(y0 + 1, height - 1);
  const double fy = yc - y0;
  int x0 = 0;
  int x1 = 0;
  double fx = 0.0;
  if (wraps) {
    const double xf = std::floor(x);
    fx = x - xf;
    const auto xi = static_cast<long long>(xf);
    x0 = static_cast<int>(((xi % width) + width) % width);
    x1 = (x0 + 1) % width;
  } else {
    const double xc = std::clamp(x, 0.0, static_cast<double>(width - 1));
    x0 = static_cast<int>(std::floor(xc));
    x1 = std::min(x0 + 1, width - 1);
    fx = xc - x0;
  }
  auto at = [&](int xx, int yy) {
    return static_cast<double>(px[(static_cast<std::size_t>(yy) * static_cast<std::size_t>(width) +
                                   static_cast<std::size_t>(xx)) *
                                      static_cast<std::size_t>(channels) +
                                  static_cast<std::size_t>(channel)]);
  };
  const double v[4] = {at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1)};
  const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  const auto missing = [noData](double s) { return std::isnan(s) || s == noData; };
  if (missing(v[0]) || missing(v[1]) || missing(v[2]) || missing(v[3])) {
    int best = -1;
    for (int k = 0; k < 4; ++k)
      if (!missing(v[k]) && (best < 0 || w[k] > w[best])) best = k;
    return best < 0 ? std::numeric_limits<double>::quiet_NaN() : v[best];
  }
  const double top = v[0] * (1 - fx) + v[1] * fx;
  const double bottom = v[2] * (1 - fx) + v[3] * fx;
  return top * (1 - fy) + bottom * fy;
}

} // namespace

std::expected<LocalRasterSource, std::string> LocalRasterSource::open(const fs::path& image) {
  auto georef = readWorldFile(worldFileFor(image));
  if (!georef) return std::unexpected(georef.error());
  // The header only: neither decoding nor the imaging module (and so OpenImageIO) at open.
  auto header = readRasterHeader(image);
  if (!header) return std::unexpected(header.error());
  LocalRasterSource src;
  if (*header) {
    src.width_ = (*header)->width;
    src.height_ = (*header)->height;
    src.channels_ = std::min((*header)->channels, 4);
    src.sampleType_ = (*header)->sampleType;
  } else {
    // A format (or variant) the header reader does not model: the imaging module reads it.
    auto api = imaging::table();
    if (!api) return std::unexpected("cannot open " + image.string() + ": " + api.error());
    TellusImagingRasterInfo info{};
    imaging::ErrorSink errors;
    if ((*api)->probeRaster(image.c_str(), &info, errors.get()) != TELLUS_IMAGING_OK)
      return std::unexpected(errors.error());
    if (info.width <= 0 || info.height <= 0 || info.channels <= 0)
      return std::unexpected("cannot open " + image.string() + ": empty image");
    src.width_ = info.width;
    src.height_ = info.height;
    src.channels_ = std::min(info.channels, 4);
    src.sampleType_ = sampleTypeOf(info.fileFormat);
  }
  src.georef_ = *georef;
  src.pixels_ = std::make_shared<Pixels>();
  src.pixels_->file = image;
  return src;
}

std::expected<const LocalRasterSource::Pixels*, std::string> LocalRasterSource::pixels() const {
  Pixels& p = *pixels_;
  std::call_once(p.once, [&] {
    const std::string name = p.file.string();
    auto api = imaging::table();
    if (!api) {
      p.error = "cannot read " + name + ": " + api.error();
    } else {
      SamplesSink sink;
      if ((*api)->readRaster(p.file.c_str(), 4, &sink.info, sink.get()) != TELLUS_IMAGING_OK) {
        p.error = sink.error();
      } else if (sink.info.width != width_ || sink.info.height != height_ ||
                 sink.info.channels != channels_ ||
                 std::holds_alternative<std::monostate>(sink.samples)) {
        p.error = "cannot read " + name + ": it decodes as " + std::to_string(sink.info.width) +
                  "x" + std::to_string(sink.info.height) + "x" +
                  std::to_string(sink.info.channels) + ", its header said " +
                  std::to_string(width_) + "x" + std::to_string(height_) + "x" +
                  std::to_string(channels_);
      } else {
        p.samples = std::move(sink.samples);
      }
    }
    p.done.store(true, std::memory_order_release);
  });
  if (!p.error.empty()) return std::unexpected(p.error);
  return &p;
}

std::expected<void, std::string> LocalRasterSource::load() const {
  auto p = pixels();
  if (!p) return std::unexpected(p.error());
  return {};
}

bool LocalRasterSource::loaded() const noexcept {
  return pixels_ && pixels_->done.load(std::memory_order_acquire) && pixels_->error.empty();
}

Sector LocalRasterSource::coverage() const noexcept {
  return Sector{georef_.west,
                georef_.north - georef_.pixelHeightDeg * height_,
                georef_.west + georef_.pixelWidthDeg * width_,
                georef_.north};
}

double
LocalRasterSource::sample(double latDeg, double lonDeg, int channel, double noData) const noexcept {
  if (!std::isfinite(latDeg) || !std::isfinite(lonDeg) || channel < 0 || channel >= channels_) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  try {
    auto p = pixels();
    if (!p) return std::numeric_limits<double>::quiet_NaN();
    return std::visit(
        [&](const auto& v) -> double {
          using V = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<V, std::monostate>) {
            return std::numeric_limits<double>::quiet_NaN();
          } else {
            return sampleFrom(
                v.data(), width_, height_, channels_, georef_, latDeg, lonDeg, channel, noData);
          }
        },
        (*p)->samples);
  } catch (...) { // std::call_once may throw std::system_error
    return std::numeric_limits<double>::quiet_NaN();
  }
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
  const bool elevation = mimeType == "application/bil16" || mimeType == "image/tiff";
  const bool png = mimeType == "image/png";
  if (!elevation && !png && mimeType != "image/jpeg")
    return std::unexpected("unsupported format " + std::string(mimeType));
  auto p = pixels(); // decoded on the first tile
  if (!p) return std::unexpected(p.error());
  return std::visit(
      [&](const auto& v) -> std::expected<std::vector<std::byte>, std::string> {
        using V = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<V, std::monostate>) {
          return std::unexpected("no pixels");
        } else {
          const auto* px = v.data();
          // Heights and values: a source sample equal to the tile's no-data value is no data
          // too (a grid with land masked, data/sst_coads_jan_int16.tif), never mixed in.
          const double sourceNoData =
              elevation ? static_cast<double>(noData) : std::numeric_limits<double>::quiet_NaN();
          const auto sample = [&](double lat, double lon, int channel) {
            return sampleFrom(
                px, width_, height_, channels_, georef_, lat, lon, channel, sourceNoData);
          };
          const auto w = static_cast<std::size_t>(width);
          const auto h = static_cast<std::size_t>(height);
          const double dx = (box.east - box.west) / width;
          const double dy = (box.north - box.south) / height;
          if (elevation) {
            std::vector<std::int16_t> heights(w * h);
            for (std::size_t j = 0; j < h; ++j) {
              const double lat = box.north - (static_cast<double>(j) + 0.5) * dy;
              for (std::size_t i = 0; i < w; ++i) {
                const double lon = box.west + (static_cast<double>(i) + 0.5) * dx;
                const double s = sample(lat, lon, 0);
                heights[j * w + i] =
                    std::isnan(s)
                        ? noData
                        : static_cast<std::int16_t>(std::clamp(std::round(s), -32767.0, 32767.0));
              }
            }
            return encodeHeights(mimeType, width, height, heights.data());
          }
          const int outChannels = png ? 4 : 3;
          const auto oc = static_cast<std::size_t>(outChannels);
          std::vector<unsigned char> rgba(w * h * oc);
          for (std::size_t j = 0; j < h; ++j) {
            const double lat = box.north - (static_cast<double>(j) + 0.5) * dy;
            for (std::size_t i = 0; i < w; ++i) {
              const double lon = box.west + (static_cast<double>(i) + 0.5) * dx;
              unsigned char* out = &rgba[(j * w + i) * oc];
              const double first = sample(lat, lon, 0);
              const bool inside = !std::isnan(first);
              for (int c = 0; c < 3; ++c) {
                const double s = inside ? sample(lat, lon, std::min(c, channels_ - 1)) : 0.0;
                out[c] = static_cast<unsigned char>(std::clamp(std::round(s), 0.0, 255.0));
              }
              if (png) {
                const double a =
                    (inside && channels_ == 4) ? sample(lat, lon, 3) : (inside ? 255.0 : 0.0);
                out[3] = static_cast<unsigned char>(std::clamp(std::round(a), 0.0, 255.0));
              }
            }
          }
          return encodeImage(mimeType, width, height, outChannels, rgba.data(), true);
        }
      },
      (*p)->samples);
}

} // namespace tellus
