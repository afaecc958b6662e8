#include <tellus/values/Sample.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <cmath>
#include <limits>

namespace tellus::values {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool startsWithNoCase(std::string_view text, std::string_view prefix) noexcept {
  if (text.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const char c = text[i];
    const char lower = c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
    if (lower != prefix[i]) return false;
  }
  return true;
}

} // namespace

float sample(const ValueRaster& raster, double x, double y) noexcept {
  const int w = raster.width, h = raster.height;
  if (w <= 0 || h <= 0 || !(x >= 0.0 && x <= w && y >= 0.0 && y <= h)) return kNaN;
  const AxisTexels<double> c = axisTexels(x, w), r = axisTexels(y, h);
  return static_cast<float>(bilinearValue(static_cast<double>(raster.at(c.i0, r.i0)),
                                          static_cast<double>(raster.at(c.i1, r.i0)),
                                          static_cast<double>(raster.at(c.i0, r.i1)),
                                          static_cast<double>(raster.at(c.i1, r.i1)),
                                          c.f,
                                          r.f));
}

std::string_view encodingName(Encoding encoding) noexcept {
  switch (encoding) {
  case Encoding::Int16:
    return "int16";
  case Encoding::UInt16:
    return "uint16";
  case Encoding::Float32:
    return "float32";
  }
  return "";
}

std::optional<Encoding> parseEncoding(std::string_view name) noexcept {
  for (Encoding e : {Encoding::Int16, Encoding::UInt16, Encoding::Float32})
    if (encodingName(e) == name) return e;
  return std::nullopt;
}

std::string_view containerName(Container container) noexcept {
  switch (container) {
  case Container::Bil:
    return "bil";
  case Container::Tiff:
    return "tiff";
  case Container::Png:
    return "png";
  }
  return "";
}

std::optional<Container> parseContainer(std::string_view name) noexcept {
  for (Container c : {Container::Bil, Container::Tiff, Container::Png})
    if (containerName(c) == name) return c;
  return std::nullopt;
}

std::optional<Container> containerForMimeType(std::string_view mimeType) noexcept {
  if (startsWithNoCase(mimeType, "application/bil")) return Container::Bil;
  if (startsWithNoCase(mimeType, "image/tiff")) return Container::Tiff;
  if (startsWithNoCase(mimeType, "image/png")) return Container::Png;
  return std::nullopt;
}

} // namespace tellus::values
