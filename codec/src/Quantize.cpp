#include <tellus/codec/Quantize.hpp>

#include <algorithm>

namespace tellus::codec {

namespace {

constexpr int kBins = 1 << 15; // 5 bits per channel

int binOf(const std::uint8_t* p) noexcept {
  return ((p[0] >> 3) << 10) | ((p[1] >> 3) << 5) | (p[2] >> 3);
}

int channelOf(int bin, int c) noexcept {
  return (bin >> (10 - 5 * c)) & 31;
}

struct Box {
  std::size_t begin, end; // a range of `used`
  std::uint64_t count;
  int longest; // channel with the widest range
  int range;
};

/** A median cut of the colours of one image on a 5-bit-per-channel histogram: the box with the
 * most pixels is split at its weighted median on its widest channel until there are as many
 * boxes as colours; each box's colour is the mean of its pixels. */
class MedianCut {
public:
  MedianCut(const std::uint8_t* pixels, int channels, std::size_t count)
      : pixels_(pixels), channels_(channels), step_(static_cast<std::size_t>(channels)),
        count_(count) {}

  PalettedImage run() {
    histogram();
    const std::size_t maxColours = transparent_ ? 255 : 256;
    if (!used_.empty()) boxes_.push_back(describe(0, used_.size()));
    while (boxes_.size() < maxColours && splitLargest()) {
    }
    return paletted();
  }

private:
  bool isTransparent(const std::uint8_t* p) const noexcept { return channels_ == 4 && p[3] < 128; }

  /** Pixels and their channel sums per bin (transparent pixels apart); the bins in use. */
  void histogram() {
    hist_.assign(kBins, 0);
    sums_.assign(kBins, {0, 0, 0});
    for (std::size_t i = 0; i < count_; ++i) {
      const std::uint8_t* p = pixels_ + i * step_;
      if (isTransparent(p)) {
        transparent_ = true;
        continue;
      }
      const int b = binOf(p);
      ++hist_[static_cast<std::size_t>(b)];
      auto& s = sums_[static_cast<std::size_t>(b)];
      s[0] += p[0];
      s[1] += p[1];
      s[2] += p[2];
    }
    for (int b = 0; b < kBins; ++b)
      if (hist_[static_cast<std::size_t>(b)] != 0) used_.push_back(b);
  }

  Box describe(std::size_t begin, std::size_t end) const {
    Box box{begin, end, 0, 0, -1};
    int lo[3] = {31, 31, 31}, hi[3] = {0, 0, 0};
    for (std::size_t k = begin; k < end; ++k) {
      box.count += hist_[static_cast<std::size_t>(used_[k])];
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], channelOf(used_[k], c));
        hi[c] = std::max(hi[c], channelOf(used_[k], c));
      }
    }
    for (int c = 0; c < 3; ++c) {
      if (hi[c] - lo[c] > box.range) {
        box.range = hi[c] - lo[c];
        box.longest = c;
      }
    }
    return box;
  }

  /** Splits the box with the most pixels that can still be split; false when every box is one
   * colour. */
  bool splitLargest() {
    std::size_t pick = boxes_.size();
    for (std::size_t k = 0; k < boxes_.size(); ++k) {
      if (boxes_[k].range > 0 && (pick == boxes_.size() || boxes_[k].count > boxes_[pick].count))
        pick = k;
    }
    if (pick == boxes_.size()) return false;
    const Box b = boxes_[pick];
    const std::size_t cut = medianCut(b);
    boxes_[pick] = describe(b.begin, cut);
    boxes_.push_back(describe(cut, b.end));
    return true;
  }

  /** Where `b` is cut: its bins sorted on its widest channel, the weighted median, kept inside
   * the range so both halves are non-empty and never between two bins of the same value there. */
  std::size_t medianCut(const Box& b) {
    const int c = b.longest;
    std::sort(used_.begin() + static_cast<std::ptrdiff_t>(b.begin),
              used_.begin() + static_cast<std::ptrdiff_t>(b.end),
              [c](int x, int y) { return channelOf(x, c) < channelOf(y, c); });
    std::uint64_t half = 0;
    std::size_t cut = b.begin + 1;
    for (std::size_t k = b.begin; k < b.end - 1; ++k) {
      half += hist_[static_cast<std::size_t>(used_[k])];
      cut = k + 1;
      if (half * 2 >= b.count) break;
    }
    // Move the cut to the nearest change (one exists, the box's range on this axis is not zero).
    const auto same = [&](std::size_t k) {
      return channelOf(used_[k], c) == channelOf(used_[k - 1], c);
    };
    std::size_t forward = cut;
    while (forward < b.end && same(forward))
      ++forward;
    if (forward < b.end) return forward;
    while (cut > b.begin + 1 && same(cut))
      --cut;
    return cut;
  }

  /** The palette (transparent first when any pixel is) and each pixel's index. */
  PalettedImage paletted() const {
    PalettedImage out;
    std::vector<std::uint8_t> indexOfBin(kBins, 0);
    if (transparent_) out.palette.push_back({0, 0, 0, 0});
    for (const Box& b : boxes_) {
      const auto index = static_cast<std::uint8_t>(out.palette.size());
      out.palette.push_back(meanColour(b));
      for (std::size_t k = b.begin; k < b.end; ++k)
        indexOfBin[static_cast<std::size_t>(used_[k])] = index;
    }
    if (out.palette.empty()) out.palette.push_back({0, 0, 0, 255});
    out.indices.resize(count_);
    for (std::size_t i = 0; i < count_; ++i) {
      const std::uint8_t* p = pixels_ + i * step_;
      out.indices[i] = isTransparent(p) ? 0 : indexOfBin[static_cast<std::size_t>(binOf(p))];
    }
    return out;
  }

  std::array<std::uint8_t, 4> meanColour(const Box& b) const {
    std::array<std::uint64_t, 3> s{0, 0, 0};
    for (std::size_t k = b.begin; k < b.end; ++k) {
      const auto& bs = sums_[static_cast<std::size_t>(used_[k])];
      for (int c = 0; c < 3; ++c)
        s[static_cast<std::size_t>(c)] += bs[static_cast<std::size_t>(c)];
    }
    std::array<std::uint8_t, 4> colour{};
    for (std::size_t c = 0; c < 3; ++c)
      colour[c] =
          static_cast<std::uint8_t>((s[c] + b.count / 2) / std::max<std::uint64_t>(b.count, 1));
    colour[3] = 255;
    return colour;
  }

  const std::uint8_t* pixels_;
  int channels_;
  std::size_t step_;
  std::size_t count_;
  bool transparent_ = false;
  std::vector<std::uint32_t> hist_;
  std::vector<std::array<std::uint64_t, 3>> sums_;
  std::vector<int> used_;
  std::vector<Box> boxes_;
};

} // namespace

PalettedImage quantize(const std::uint8_t* pixels, int channels, std::size_t count) {
  return MedianCut(pixels, channels, count).run();
}

} // namespace tellus::codec
