#include "TextureDecoder.hpp"

#include "Codec.hpp"
#include "ValueTexture.hpp"

#include <algorithm>
#include <cerrno>
#include <sys/resource.h>
#include <unistd.h>
#include <utility>

namespace tellus::planet {

std::vector<MipLevel> buildMips(MipLevel base) {
  std::vector<MipLevel> levels;
  levels.push_back(std::move(base));
  while (levels.back().width > 1 || levels.back().height > 1) {
    const MipLevel& s = levels.back();
    MipLevel d;
    d.width = std::max(1, s.width / 2);
    d.height = std::max(1, s.height / 2);
    d.rgba.resize(static_cast<std::size_t>(d.width) * static_cast<std::size_t>(d.height) * 4);
    const auto sw = static_cast<std::size_t>(s.width);
    for (int y = 0; y < d.height; ++y) {
      const auto y0 = static_cast<std::size_t>(std::min(2 * y, s.height - 1));
      const auto y1 = static_cast<std::size_t>(std::min(2 * y + 1, s.height - 1));
      for (int x = 0; x < d.width; ++x) {
        const auto x0 = static_cast<std::size_t>(std::min(2 * x, s.width - 1));
        const auto x1 = static_cast<std::size_t>(std::min(2 * x + 1, s.width - 1));
        for (std::size_t c = 0; c < 4; ++c) {
          const unsigned sum =
              unsigned{s.rgba[(y0 * sw + x0) * 4 + c]} + unsigned{s.rgba[(y0 * sw + x1) * 4 + c]} +
              unsigned{s.rgba[(y1 * sw + x0) * 4 + c]} + unsigned{s.rgba[(y1 * sw + x1) * 4 + c]};
          d.rgba[(static_cast<std::size_t>(y) * static_cast<std::size_t>(d.width) +
                  static_cast<std::size_t>(x)) *
                     4 +
                 c] = static_cast<std::uint8_t>((sum + 2) / 4);
        }
      }
    }
    levels.push_back(std::move(d));
  }
  return levels;
}

namespace {

// JPEG and PNG by their magic, here; anything else through the caller's decoder (TIFF through the
// imaging module), whose answer must be the layer's tile size.
std::expected<RgbaImage, std::string>
decodeTile(const DecodeJob& job, std::size_t t, const ImageDecoder& other) {
  const auto& bytes = *job.tiles[t];
  if (!other || isJpegOrPng(bytes)) return decodeJpegOrPng(bytes);
  std::string_view type; // not `cond ? str : ""`: that is a temporary std::string
  if (t < job.contentTypes.size()) type = job.contentTypes[t];
  auto img = other(bytes, type, job.tileWidth, job.tileHeight);
  if (img && (img->width <= 0 || img->height <= 0 ||
              img->pixels.size() !=
                  static_cast<std::size_t>(img->width) * static_cast<std::size_t>(img->height) * 4))
    return std::unexpected(std::string("the image decoder gave a malformed image"));
  return img;
}

} // namespace

DecodedTexture decodeTexture(const DecodeJob& job, const ImageDecoder& other) {
  if (job.valueFormat) return decodeValueTexture(job);
  DecodedTexture out;
  out.key = job.key;
  out.tag = job.tag;
  const int w = job.width, h = job.height;
  const auto span = static_cast<int>(std::max<std::size_t>(1, job.tiles.size()));
  MipLevel base;
  base.width = w;
  base.height = h;
  base.rgba.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4, 0);
  if (!job.transparent)
    for (std::size_t i = 3; i < base.rgba.size(); i += 4)
      base.rgba[i] = 255;
  bool any = false;
  for (int t = 0; t < span; ++t) {
    const auto& bytes = job.tiles[static_cast<std::size_t>(t)];
    if (!bytes) continue;
    auto img = decodeTile(job, static_cast<std::size_t>(t), other);
    if (!img) {
      out.error = img.error();
      continue;
    }
    any = true;
    // Tile t covers texture columns [x0, x1); each texel averages the tile's columns it covers
    // (span of them for a merged node), rows mapped nearest (the tile's size normally equals ours).
    const int x0 = t * w / span, x1 = (t + 1) * w / span;
    const int iw = img->width, ih = img->height;
    for (int y = 0; y < h; ++y) {
      const int sy = std::min(ih - 1, static_cast<int>((static_cast<long>(y) * ih) / h));
      const auto src = static_cast<std::size_t>(sy) * static_cast<std::size_t>(iw) * 4;
      // Rows from the south: image row 0 (north) becomes the last texture row.
      const auto dst = static_cast<std::size_t>(h - 1 - y) * static_cast<std::size_t>(w) * 4;
      for (int x = x0; x < x1; ++x) {
        int a = static_cast<int>((static_cast<long>(x - x0) * iw) / (x1 - x0));
        int b = static_cast<int>((static_cast<long>(x - x0 + 1) * iw) / (x1 - x0));
        a = std::min(a, iw - 1);
        b = std::clamp(b, a + 1, iw);
        for (std::size_t c = 0; c < 4; ++c) {
          unsigned sum = 0;
          for (int sx = a; sx < b; ++sx)
            sum += img->pixels[src + static_cast<std::size_t>(sx) * 4 + c];
          const auto n = static_cast<unsigned>(b - a);
          base.rgba[dst + static_cast<std::size_t>(x) * 4 + c] =
              static_cast<std::uint8_t>((sum + n / 2) / n);
        }
      }
    }
  }
  if (!any) {
    if (out.error.empty()) out.error = "no tile";
    return out;
  }
  // Premultiplied alpha (see DecodedTexture); opaque texels are left as they are.
  for (std::size_t i = 0; i < base.rgba.size(); i += 4) {
    const unsigned a = base.rgba[i + 3];
    if (a == 255) continue;
    for (std::size_t c = 0; c < 3; ++c)
      base.rgba[i + c] = static_cast<std::uint8_t>((base.rgba[i + c] * a + 127) / 255);
  }
  out.levels = buildMips(std::move(base));
  for (const auto& l : out.levels)
    out.bytes += l.rgba.size();
  out.ok = true;
  return out;
}

TextureDecoder::TextureDecoder(int threads, int nice, ImageDecoder other)
    : other_(std::move(other)), nice_(nice) {
  for (int i = 0; i < std::max(1, threads); ++i)
    workers_.emplace_back([this](std::stop_token st) { run(st); });
}

TextureDecoder::~TextureDecoder() {
  for (auto& w : workers_)
    w.request_stop();
  wake_.notify_all();
  workers_.clear(); // joins
}

void TextureDecoder::submit(DecodeJob job) {
  ++submitted_;
  outbox_.push_back(std::move(job));
  flush();
}

void TextureDecoder::flush() {
  if (outbox_.empty()) return;
  {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;
    for (DecodeJob& j : outbox_)
      queue_.push_back(std::move(j));
  }
  outbox_.clear();
  wake_.notify_all();
}

std::vector<DecodedTexture> TextureDecoder::takeDone() {
  flush();
  std::vector<DecodedTexture> out;
  {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return out;
    out = std::exchange(done_, {});
  }
  taken_ += out.size();
  return out;
}

std::size_t TextureDecoder::pending() const {
  return submitted_ - taken_;
}

void TextureDecoder::run(std::stop_token stop) {
  if (nice_ != 0) {
    // Linux: PRIO_PROCESS with a thread id sets that thread alone.
    const auto self = static_cast<id_t>(gettid());
    errno = 0;
    const int now = getpriority(PRIO_PROCESS, self);
    if (errno == 0) (void)setpriority(PRIO_PROCESS, self, std::clamp(now + nice_, -20, 19));
  }
  for (;;) {
    DecodeJob job;
    {
      std::unique_lock lock(mutex_);
      if (!wake_.wait(lock, stop, [&] { return !queue_.empty(); })) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    DecodedTexture t = decodeTexture(job, other_);
    std::lock_guard lock(mutex_);
    done_.push_back(std::move(t));
  }
}

} // namespace tellus::planet
