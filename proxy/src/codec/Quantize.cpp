#include "codec/Quantize.hpp"

#include <algorithm>

namespace tellus {

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

} // namespace

PalettedImage quantize(const std::uint8_t* pixels, int channels, std::size_t count) {
  const auto step = static_cast<std::size_t>(channels);
  std::vector<std::uint32_t> hist(kBins, 0);
  std::vector<std::array<std::uint64_t, 3>> sums(kBins, {0, 0, 0});
  bool transparent = false;
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint8_t* p = pixels + i * step;
    if (channels == 4 && p[3] < 128) {
      transparent = true;
      continue;
    }
    const int b = binOf(p);
    ++hist[static_cast<std::size_t>(b)];
    auto& s = sums[static_cast<std::size_t>(b)];
    s[0] += p[0];
    s[1] += p[1];
    s[2] += p[2];
  }
  std::vector<int> used;
  for (int b = 0; b < kBins; ++b)
    if (hist[static_cast<std::size_t>(b)] != 0) used.push_back(b);

  const std::size_t maxColours = transparent ? 255 : 256;
  const auto describe = [&](std::size_t begin, std::size_t end) {
    Box box{begin, end, 0, 0, -1};
    int lo[3] = {31, 31, 31}, hi[3] = {0, 0, 0};
    for (std::size_t k = begin; k < end; ++k) {
      box.count += hist[static_cast<std::size_t>(used[k])];
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], channelOf(used[k], c));
        hi[c] = std::max(hi[c], channelOf(used[k], c));
      }
    }
    for (int c = 0; c < 3; ++c) {
      if (hi[c] - lo[c] > box.range) {
        box.range = hi[c] - lo[c];
        box.longest = c;
      }
    }
    return box;
  };
  std::vector<Box> boxes;
  if (!used.empty()) boxes.push_back(describe(0, used.size()));
  while (boxes.size() < maxColours) {
    // Split the box with the most pixels that can still be split.
    std::size_t pick = boxes.size();
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      if (boxes[k].range > 0 && (pick == boxes.size() || boxes[k].count > boxes[pick].count))
        pick = k;
    }
    if (pick == boxes.size()) break; // every box is one colour
    const Box b = boxes[pick];
    const int c = b.longest;
    std::sort(used.begin() + static_cast<std::ptrdiff_t>(b.begin),
              used.begin() + static_cast<std::ptrdiff_t>(b.end),
              [c](int x, int y) { return channelOf(x, c) < channelOf(y, c); });
    // The weighted median, kept inside the range so both halves are non-empty.
    std::uint64_t half = 0;
    std::size_t cut = b.begin + 1;
    for (std::size_t k = b.begin; k < b.end - 1; ++k) {
      half += hist[static_cast<std::size_t>(used[k])];
      cut = k + 1;
      if (half * 2 >= b.count) break;
    }
    // Never split between two bins of the same value on the axis: move the cut to the nearest
    // change (one exists, the box's range on this axis is not zero).
    const auto same = [&](std::size_t k) {
      return channelOf(used[k], c) == channelOf(used[k - 1], c);
    };
    std::size_t forward = cut;
    while (forward < b.end && same(forward))
      ++forward;
    if (forward < b.end) {
      cut = forward;
    } else {
      while (cut > b.begin + 1 && same(cut))
        --cut;
    }
    boxes[pick] = describe(b.begin, cut);
    boxes.push_back(describe(cut, b.end));
  }

  PalettedImage out;
  std::vector<std::uint8_t> indexOfBin(kBins, 0);
  if (transparent) out.palette.push_back({0, 0, 0, 0});
  for (const Box& b : boxes) {
    std::array<std::uint64_t, 3> s{0, 0, 0};
    for (std::size_t k = b.begin; k < b.end; ++k) {
      const auto& bs = sums[static_cast<std::size_t>(used[k])];
      for (int c = 0; c < 3; ++c)
        s[static_cast<std::size_t>(c)] += bs[static_cast<std::size_t>(c)];
    }
    const auto index = static_cast<std::uint8_t>(out.palette.size());
    std::array<std::uint8_t, 4> colour{};
    for (std::size_t c = 0; c < 3; ++c)
      colour[c] =
          static_cast<std::uint8_t>((s[c] + b.count / 2) / std::max<std::uint64_t>(b.count, 1));
    colour[3] = 255;
    out.palette.push_back(colour);
    for (std::size_t k = b.begin; k < b.end; ++k)
      indexOfBin[static_cast<std::size_t>(used[k])] = index;
  }
  if (out.palette.empty()) out.palette.push_back({0, 0, 0, 255});
  out.indices.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint8_t* p = pixels + i * step;
    out.indices[i] =
        channels == 4 && p[3] < 128 ? 0 : indexOfBin[static_cast<std::size_t>(binOf(p))];
  }
  return out;
}

} // namespace tellus
