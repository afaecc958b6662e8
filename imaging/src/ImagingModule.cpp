// The imaging module: everything tellus does with OpenImageIO, behind the C function table of
// tellus/imaging/ImagingApi.hpp. Built as a MODULE library and dlopen()ed by the proxy on first use
// (proxy/src/imaging/ImagingLoader.cpp), so that a process that only serves cached tiles never maps
// OpenImageIO.

#include <tellus/imaging/ImagingApi.hpp>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <new>
#include <string>
#include <string_view>
#include <vector>

namespace {

constexpr const char* kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf";

std::int32_t fail(const TellusImagingSink* out, std::string_view message) noexcept {
  if (out && out->fail) out->fail(out->context, message.data(), message.size());
  return TELLUS_IMAGING_FAILED;
}

/** The caller's storage for `size` bytes (nullptr and a reported failure when there is none). */
void* allocate(const TellusImagingSink* out, std::size_t size) noexcept {
  void* p = out && out->allocate ? out->allocate(out->context, size) : nullptr;
  if (!p) fail(out, "out of memory for " + std::to_string(size) + " bytes");
  return p;
}

/** Runs an entry point's body; no exception leaves the module. */
template <class F> std::int32_t guarded(const TellusImagingSink* out, F&& body) noexcept {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return fail(out, "out of memory");
  } catch (const std::exception& e) {
    return fail(out, e.what());
  } catch (...) {
    return fail(out, "unknown error in the imaging module");
  }
}

std::int32_t encode(const char* formatName,
                    const OIIO::ImageSpec& spec,
                    const void* pixels,
                    OIIO::TypeDesc type,
                    const TellusImagingSink* out) {
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput vec(buffer);
  auto output = OIIO::ImageOutput::create(formatName);
  if (!output) return fail(out, std::string("no encoder for ") + formatName);
  if (!output->set_ioproxy(&vec))
    return fail(out, std::string("encoder cannot write to memory: ") + formatName);
  const std::string name = std::string("tile.") + formatName;
  if (!output->open(name, spec) || !output->write_image(type, pixels) || !output->close()) {
    return fail(out, "cannot encode " + name + ": " + output->geterror());
  }
  if (buffer.empty()) return fail(out, "cannot encode " + name + ": no bytes written");
  void* dst = allocate(out, buffer.size());
  if (!dst) return TELLUS_IMAGING_FAILED;
  std::memcpy(dst, buffer.data(), buffer.size());
  return TELLUS_IMAGING_OK;
}

std::int32_t encodeImage(const char* format,
                         std::int32_t width,
                         std::int32_t height,
                         std::int32_t channels,
                         const std::uint8_t* pixels,
                         const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!format || !pixels || width <= 0 || height <= 0 ||
        (channels != 1 && channels != 3 && channels != 4))
      return fail(out, "bad image shape");
    const std::string_view f(format);
    if (f == "png") {
      return encode("png",
                    OIIO::ImageSpec(width, height, channels, OIIO::TypeDesc::UINT8),
                    pixels,
                    OIIO::TypeDesc::UINT8,
                    out);
    }
    if (f == "tiff") { // a picture as TIFF: 8-bit grey, RGB or RGBA, zip-compressed
      OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
      spec.attribute("compression", "zip");
      if (channels == 4) spec.alpha_channel = 3;
      return encode("tiff", spec, pixels, OIIO::TypeDesc::UINT8, out);
    }
    if (f != "jpeg") return fail(out, "cannot encode " + std::string(f));
    if (channels == 4) return fail(out, "JPEG has no alpha channel");
    OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
    spec.attribute("CompressionQuality", 90);
    return encode("jpg", spec, pixels, OIIO::TypeDesc::UINT8, out);
  });
}

std::int32_t encodeHeightsTiff(std::int32_t width,
                               std::int32_t height,
                               const std::int16_t* heights,
                               const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!heights || width <= 0 || height <= 0) return fail(out, "bad image shape");
    OIIO::ImageSpec spec(width, height, 1, OIIO::TypeDesc::INT16);
    spec.attribute("compression", "zip");
    return encode("tiff", spec, heights, OIIO::TypeDesc::INT16, out);
  });
}

std::int32_t drawBlank(std::int32_t width,
                       std::int32_t height,
                       const float* rgba,
                       const char* text,
                       std::size_t textLength,
                       const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!rgba || width <= 0 || height <= 0) return fail(out, "bad image shape");
    OIIO::ImageBuf buf(OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8));
    OIIO::ImageBufAlgo::fill(buf, OIIO::cspan<float>(rgba, 4));
    std::error_code ec;
    if (text && textLength > 0 && std::filesystem::exists(kFont, ec)) {
      const float ink[4] = {0.0f, 0.0f, 0.0f, 1.0f};
      const int size = std::clamp(height / 12, 10, 16);
      OIIO::ImageBufAlgo::render_text(
          buf, 4, size + 4, std::string(text, textLength), size, kFont, ink);
    }
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4;
    void* px = allocate(out, n);
    if (!px) return TELLUS_IMAGING_FAILED;
    if (!buf.get_pixels(OIIO::ROI::All(), OIIO::TypeDesc::UINT8, px))
      return fail(out, "cannot draw a blank image: " + buf.geterror());
    return TELLUS_IMAGING_OK;
  });
}

std::int32_t fileFormatOf(const OIIO::TypeDesc& format) noexcept {
  if (format == OIIO::TypeDesc::UINT8) return 1;
  if (format == OIIO::TypeDesc::INT16) return 2;
  if (format == OIIO::TypeDesc::UINT16) return 3;
  if (format == OIIO::TypeDesc::FLOAT) return 4;
  return 0;
}

std::unique_ptr<OIIO::ImageInput> openFile(const char* path, const TellusImagingSink* out) {
  auto in = OIIO::ImageInput::open(path);
  if (!in)
    fail(out, std::string("cannot open ") + path + ": " + OIIO::geterror());
  else
    in->threads(1);
  return in;
}

std::int32_t probeRaster(const char* path,
                         TellusImagingRasterInfo* info,
                         const TellusImagingSink* errors) noexcept {
  return guarded(errors, [&]() -> std::int32_t {
    if (!path || !info) return fail(errors, "no path");
    auto in = openFile(path, errors);
    if (!in) return TELLUS_IMAGING_FAILED;
    const OIIO::ImageSpec& spec = in->spec();
    *info = TellusImagingRasterInfo{};
    info->width = spec.width;
    info->height = spec.height;
    info->channels = spec.nchannels;
    info->fileFormat = fileFormatOf(spec.format);
    info->sampleType = spec.format == OIIO::TypeDesc::UINT8   ? TELLUS_IMAGING_UINT8
                       : spec.format == OIIO::TypeDesc::INT16 ? TELLUS_IMAGING_INT16
                                                              : TELLUS_IMAGING_FLOAT32;
    return TELLUS_IMAGING_OK;
  });
}

std::int32_t readRaster(const char* path,
                        std::int32_t maxChannels,
                        TellusImagingRasterInfo* info,
                        const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!path || !info || maxChannels < 1) return fail(out, "no path");
    auto in = openFile(path, out);
    if (!in) return TELLUS_IMAGING_FAILED;
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
      return fail(out, std::string("cannot read ") + path + ": empty image");
    const int channels = std::min(spec.nchannels, maxChannels);
    *info = TellusImagingRasterInfo{};
    info->width = spec.width;
    info->height = spec.height;
    info->channels = channels;
    info->fileFormat = fileFormatOf(spec.format);
    const auto n = static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
                   static_cast<std::size_t>(channels);
    bool ok = false;
    if (spec.format == OIIO::TypeDesc::UINT8 || spec.format == OIIO::TypeDesc::INT16) {
      // Kept as they are: 8-bit imagery as 0..255, Int16 heights in metres.
      const bool u8 = spec.format == OIIO::TypeDesc::UINT8;
      info->sampleType = u8 ? TELLUS_IMAGING_UINT8 : TELLUS_IMAGING_INT16;
      void* px = allocate(out, n * (u8 ? 1 : 2));
      if (!px) return TELLUS_IMAGING_FAILED;
      ok = in->read_image(0, 0, 0, channels, spec.format, px);
    } else {
      // Other measurements keep their raw values (no normalisation to 0..1), as float.
      info->sampleType = TELLUS_IMAGING_FLOAT32;
      std::vector<double> raw(n);
      ok = in->read_image(0, 0, 0, channels, OIIO::TypeDesc::DOUBLE, raw.data());
      if (spec.format == OIIO::TypeDesc::UINT16) {
        for (auto& x : raw)
          x = std::round(x * 65535.0);
      }
      auto* px = static_cast<float*>(allocate(out, n * sizeof(float)));
      if (!px) return TELLUS_IMAGING_FAILED;
      std::transform(raw.begin(), raw.end(), px, [](double d) { return static_cast<float>(d); });
    }
    if (!ok) return fail(out, std::string("cannot read ") + path + ": " + in->geterror());
    return TELLUS_IMAGING_OK;
  });
}

std::int32_t decodeImage(const void* bytes,
                         std::size_t size,
                         const char* format,
                         std::int32_t expectedWidth,
                         std::int32_t expectedHeight,
                         TellusImagingDecodeResult* result,
                         const TellusImagingSink* errors) noexcept {
  return guarded(errors, [&]() -> std::int32_t {
    if (!bytes || !format || !result) return fail(errors, "nothing to decode");
    const std::string_view f(format);
    const char* name = f == "jpeg" ? "tile.jpg" : f == "png" ? "tile.png" : "tile.tif";
    OIIO::Filesystem::IOMemReader memory(bytes, size);
    // By format name: OpenImageIO 2.4 would look for a file called `name` on disk otherwise.
    auto in = OIIO::ImageInput::create(format);
    if (!in) return TELLUS_IMAGING_NO_CODEC;
    // Decoded on the caller's thread: a tile is small, and OpenImageIO's worker pool would only
    // oversubscribe the cores that tellus's own workers use.
    in->threads(1);
    OIIO::ImageSpec spec0;
    if (!in->set_ioproxy(&memory) || !in->open(name, spec0)) {
      fail(errors, in->has_error() ? in->geterror() : OIIO::geterror());
      return TELLUS_IMAGING_OPEN_FAILED;
    }
    in->threads(1); // again: open() may reset it
    const OIIO::ImageSpec& spec = in->spec();
    *result = TellusImagingDecodeResult{spec.width, spec.height, spec.nchannels};
    if (spec.width != expectedWidth || spec.height != expectedHeight || spec.nchannels < 1 ||
        spec.nchannels > 16)
      return TELLUS_IMAGING_SHAPE;
    bool ok = true;
    if (spec.tile_width == 0) {
      // Row by row into one row: OpenImageIO 2.4's whole-image TIFF read starts its worker pool
      // even with threads(1); the single-scanline path does not.
      std::vector<unsigned char> row(static_cast<std::size_t>(spec.width) *
                                     static_cast<std::size_t>(spec.nchannels));
      for (int y = 0; y < spec.height && ok; ++y)
        ok = in->read_scanline(y, 0, OIIO::TypeDesc::UINT8, row.data());
    } else {
      std::vector<unsigned char> pixels(static_cast<std::size_t>(spec.width) *
                                        static_cast<std::size_t>(spec.height) *
                                        static_cast<std::size_t>(spec.nchannels));
      ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, pixels.data());
    }
    // OpenImageIO 2.4 reports a truncated JPEG or TIFF only as error text: the reads succeed (with
    // grey or missing rows) and has_error() is false, so the text is what counts.
    const std::string error = in->geterror();
    in->close();
    if (!ok || !error.empty()) {
      fail(errors, error);
      return TELLUS_IMAGING_READ_FAILED;
    }
    return TELLUS_IMAGING_OK;
  });
}

std::int32_t decodePixels(const void* bytes,
                          std::size_t size,
                          const char* format,
                          std::int32_t sampleType,
                          std::int32_t expectedWidth,
                          std::int32_t expectedHeight,
                          TellusImagingRasterInfo* info,
                          const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!bytes || !format || !info) return fail(out, "nothing to decode");
    if (sampleType != TELLUS_IMAGING_UINT8 && sampleType != TELLUS_IMAGING_INT16)
      return fail(out, "decodePixels: sample type must be UINT8 or INT16");
    const std::string_view f(format);
    const char* name = f == "jpeg" ? "tile.jpg" : f == "png" ? "tile.png" : "tile.tif";
    OIIO::Filesystem::IOMemReader memory(bytes, size);
    auto in = OIIO::ImageInput::create(format);
    if (!in) return TELLUS_IMAGING_NO_CODEC;
    in->threads(1);
    OIIO::ImageSpec spec0;
    if (!in->set_ioproxy(&memory) || !in->open(name, spec0)) {
      fail(out, in->has_error() ? in->geterror() : OIIO::geterror());
      return TELLUS_IMAGING_OPEN_FAILED;
    }
    in->threads(1);
    const OIIO::ImageSpec& spec = in->spec();
    const int fileChannels = spec.nchannels;
    *info = TellusImagingRasterInfo{spec.width, spec.height, fileChannels, sampleType, 0, {}};
    if (spec.width != expectedWidth || spec.height != expectedHeight || fileChannels < 1 ||
        fileChannels > 16)
      return TELLUS_IMAGING_SHAPE;
    const bool hasAlpha = spec.alpha_channel >= 0 || fileChannels == 2 || fileChannels == 4;
    const int channels = sampleType == TELLUS_IMAGING_INT16 ? 1 : hasAlpha ? 4 : 3;
    info->channels = channels;
    const auto w = static_cast<std::size_t>(spec.width);
    const auto h = static_cast<std::size_t>(spec.height);
    const std::size_t sampleBytes = sampleType == TELLUS_IMAGING_INT16 ? 2 : 1;
    void* dst = allocate(out, w * h * static_cast<std::size_t>(channels) * sampleBytes);
    if (!dst) return TELLUS_IMAGING_FAILED;
    bool ok = true;
    if (sampleType == TELLUS_IMAGING_INT16) {
      // Bit for bit: a 16-bit unsigned PNG's values come out as the same 16 bits.
      const OIIO::TypeDesc type =
          spec.format == OIIO::TypeDesc::UINT16 ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::INT16;
      std::vector<unsigned char> row(w * static_cast<std::size_t>(fileChannels) * 2);
      auto* heights = static_cast<unsigned char*>(dst);
      for (int y = 0; y < spec.height && ok; ++y) {
        ok = in->read_scanline(y, 0, type, row.data());
        for (std::size_t x = 0; ok && x < w; ++x)
          std::memcpy(heights + (static_cast<std::size_t>(y) * w + x) * 2,
                      row.data() + x * static_cast<std::size_t>(fileChannels) * 2,
                      2);
      }
    } else if (fileChannels == channels && spec.tile_width == 0) {
      // The common case (RGB JPEG, RGBA PNG): scanlines straight into the caller's storage.
      ok = in->read_scanlines(0, 0, 0, spec.height, 0, 0, fileChannels, OIIO::TypeDesc::UINT8, dst);
    } else {
      std::vector<unsigned char> all(w * h * static_cast<std::size_t>(fileChannels));
      ok = in->read_image(0, 0, 0, fileChannels, OIIO::TypeDesc::UINT8, all.data());
      auto* px = static_cast<unsigned char*>(dst);
      const auto fc = static_cast<std::size_t>(fileChannels);
      for (std::size_t i = 0; ok && i < w * h; ++i) {
        const unsigned char* s = all.data() + i * fc;
        unsigned char* d = px + i * static_cast<std::size_t>(channels);
        const bool grey = fc <= 2;
        d[0] = s[0];
        d[1] = grey ? s[0] : s[1];
        d[2] = grey ? s[0] : s[2];
        if (channels == 4)
          d[3] = fc == 2 ? s[1] : spec.alpha_channel >= 0 ? s[spec.alpha_channel] : s[3];
      }
    }
    const std::string error = in->geterror();
    in->close();
    if (!ok || !error.empty()) {
      fail(out, error.empty() ? std::string("the pixels do not decode") : error);
      return TELLUS_IMAGING_READ_FAILED;
    }
    return TELLUS_IMAGING_OK;
  });
}

std::int32_t encodePng16(std::int32_t width,
                         std::int32_t height,
                         const std::uint16_t* samples,
                         const TellusImagingSink* out) noexcept {
  return guarded(out, [&]() -> std::int32_t {
    if (!samples || width <= 0 || height <= 0) return fail(out, "bad image shape");
    return encode("png",
                  OIIO::ImageSpec(width, height, 1, OIIO::TypeDesc::UINT16),
                  samples,
                  OIIO::TypeDesc::UINT16,
                  out);
  });
}

} // namespace

extern "C" __attribute__((visibility("default"))) const TellusImagingTable* tellus_imaging_table() {
  static const TellusImagingTable table = [] {
    // tellus runs its own workers: OpenImageIO's global pool (which TIFF writing and ImageBufAlgo
    // start) would only oversubscribe the cores, and ThreadSanitizer cannot see its
    // synchronisation. Set once, before the first image is touched.
    OIIO::attribute("threads", 1);
    return TellusImagingTable{TELLUS_IMAGING_ABI_VERSION,
                              static_cast<std::uint32_t>(sizeof(TellusImagingTable)),
                              &encodeImage,
                              &encodeHeightsTiff,
                              &drawBlank,
                              &probeRaster,
                              &readRaster,
                              &decodeImage,
                              &decodePixels,
                              &encodePng16};
  }();
  return &table;
}
