#include <tellus/proxy/ImageCodec.hpp>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <cstring>
#include <filesystem>

namespace tellus {

namespace {

/** tellus runs its own workers: OpenImageIO's global pool (which TIFF writing and ImageBufAlgo
 * start) would only oversubscribe the cores, and ThreadSanitizer cannot see its synchronisation. */
void useCallingThreadOnly() {
  static const bool once = OIIO::attribute("threads", 1);
  (void)once;
}

constexpr const char* kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf";

std::expected<std::vector<std::byte>, std::string> encode(const char* formatName,
                                                          const OIIO::ImageSpec& spec,
                                                          const void* pixels,
                                                          OIIO::TypeDesc type) {
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput vec(buffer);
  auto out = OIIO::ImageOutput::create(formatName);
  if (!out) return std::unexpected(std::string("no encoder for ") + formatName);
  if (!out->set_ioproxy(&vec))
    return std::unexpected(std::string("encoder cannot write to memory: ") + formatName);
  const std::string name = std::string("tile.") + formatName;
  if (!out->open(name, spec) || !out->write_image(type, pixels) || !out->close()) {
    return std::unexpected("cannot encode " + name + ": " + out->geterror());
  }
  std::vector<std::byte> bytes(buffer.size());
  if (!buffer.empty()) std::memcpy(bytes.data(), buffer.data(), buffer.size());
  return bytes;
}

} // namespace

std::expected<std::vector<std::byte>, std::string> encodeImage(
    std::string_view mimeType, int width, int height, int channels, const std::uint8_t* pixels) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4)) {
    return std::unexpected("bad image shape");
  }
  if (mimeType == "image/png") {
    return encode("png",
                  OIIO::ImageSpec(width, height, channels, OIIO::TypeDesc::UINT8),
                  pixels,
                  OIIO::TypeDesc::UINT8);
  }
  if (mimeType != "image/jpeg") return std::unexpected("cannot encode " + std::string(mimeType));
  if (channels == 4) { // JPEG has no alpha: drop it
    const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    std::vector<std::uint8_t> rgb(n * 3);
    for (std::size_t i = 0; i < n; ++i)
      std::memcpy(&rgb[i * 3], &pixels[i * 4], 3);
    return encodeImage(mimeType, width, height, 3, rgb.data());
  }
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
  spec.attribute("CompressionQuality", 90);
  return encode("jpg", spec, pixels, OIIO::TypeDesc::UINT8);
}

std::expected<std::vector<std::byte>, std::string>
encodeHeights(std::string_view mimeType, int width, int height, const std::int16_t* heights) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (mimeType == "image/tiff") {
    OIIO::ImageSpec spec(width, height, 1, OIIO::TypeDesc::INT16);
    spec.attribute("compression", "zip");
    return encode("tiff", spec, heights, OIIO::TypeDesc::INT16);
  }
  if (mimeType != "application/bil16")
    return std::unexpected("cannot encode heights as " + std::string(mimeType));
  std::vector<std::byte> out(n * 2);
  for (std::size_t k = 0; k < n; ++k) { // little-endian whatever the host
    const auto u = static_cast<std::uint16_t>(heights[k]);
    out[2 * k] = static_cast<std::byte>(u & 0xFF);
    out[2 * k + 1] = static_cast<std::byte>(u >> 8);
  }
  return out;
}

std::expected<std::vector<std::byte>, std::string> blankImage(std::string_view mimeType,
                                                              int width,
                                                              int height,
                                                              std::optional<std::uint32_t> bgcolor,
                                                              bool transparent,
                                                              std::string_view text) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  useCallingThreadOnly();
  const std::uint32_t c = bgcolor.value_or(0xFFFFFF);
  const float rgba[4] = {static_cast<float>((c >> 16) & 0xFF) / 255.0f,
                         static_cast<float>((c >> 8) & 0xFF) / 255.0f,
                         static_cast<float>(c & 0xFF) / 255.0f,
                         transparent ? 0.0f : 1.0f};
  OIIO::ImageBuf buf(OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8));
  OIIO::ImageBufAlgo::fill(buf, rgba);
  std::error_code ec;
  if (!text.empty() && std::filesystem::exists(kFont, ec)) {
    const float ink[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    const int size = std::clamp(height / 12, 10, 16);
    OIIO::ImageBufAlgo::render_text(buf, 4, size + 4, std::string(text), size, kFont, ink);
  }
  std::vector<std::uint8_t> px(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                               4);
  buf.get_pixels(OIIO::ROI::All(), OIIO::TypeDesc::UINT8, px.data());
  return encodeImage(
      mimeType == "image/png" ? "image/png" : "image/jpeg", width, height, 4, px.data());
}

} // namespace tellus
