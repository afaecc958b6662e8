// The GL layer's CPU side, without a display (label unit, so the sanitizer runs cover it): decoding
// and composing node textures (merged polar nodes), the mip chain, and the worker pool (its nice
// value too).

#include "../../planet/gl/src/TextureDecoder.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <thread>
#include <unistd.h>

using namespace tellus;
using namespace tellus::planet;

namespace {

/** A w x h PNG: the top half one colour, the bottom half another. */
std::vector<std::byte>
twoTone(int w, int h, std::array<std::uint8_t, 3> top, std::array<std::uint8_t, 3> bottom) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 4));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto& c = y < h / 2 ? top : bottom;
      auto* p = &px[static_cast<std::size_t>((y * w + x) * 4)];
      p[0] = c[0];
      p[1] = c[1];
      p[2] = c[2];
      p[3] = 255;
    }
  return encodePngRgba(w, h, px);
}

std::array<int, 3> at(const MipLevel& l, int x, int y) {
  const auto* p = &l.rgba[static_cast<std::size_t>((y * l.width + x) * 4)];
  return {p[0], p[1], p[2]};
}

} // namespace

TEST(TextureDecoder, OneTileBecomesRowsFromTheSouthWithEveryMipLevel) {
  DecodeJob job;
  job.key = {1, 2, 3, 1};
  job.width = 16;
  job.height = 8;
  job.tiles.emplace_back(twoTone(16, 8, {200, 0, 0}, {0, 0, 100}));
  const DecodedTexture t = decodeTexture(job);
  ASSERT_TRUE(t.ok) << t.error;
  EXPECT_EQ(t.key, job.key);
  ASSERT_EQ(t.levels.size(), 5u); // 16x8, 8x4, 4x2, 2x1, 1x1
  EXPECT_EQ(t.levels.back().width, 1);
  EXPECT_EQ(t.levels.back().height, 1);
  // Row 0 is the south: the image's bottom (blue) half.
  EXPECT_EQ(at(t.levels[0], 5, 0), (std::array<int, 3>{0, 0, 100}));
  EXPECT_EQ(at(t.levels[0], 5, 7), (std::array<int, 3>{200, 0, 0}));
  // The 1 x 1 level is the mean.
  EXPECT_EQ(at(t.levels.back(), 0, 0), (std::array<int, 3>{100, 0, 50}));
  std::size_t bytes = 0;
  for (const auto& l : t.levels)
    bytes += l.rgba.size();
  EXPECT_EQ(t.bytes, bytes);
}

TEST(TextureDecoder, MergedNodeTilesAreComposedSideBySideAndDownSampledEastWest) {
  DecodeJob job;
  job.key = {3, 39, 8, 4};
  job.width = 16;
  job.height = 16;
  const std::array<std::array<std::uint8_t, 3>, 4> colours = {
      {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}}};
  for (const auto& c : colours)
    job.tiles.emplace_back(twoTone(16, 16, c, c));
  job.tiles[2].reset(); // an absent tile stays dark
  const DecodedTexture t = decodeTexture(job);
  ASSERT_TRUE(t.ok) << t.error;
  for (int i = 0; i < 4; ++i)
    for (int x = i * 4; x < i * 4 + 4; ++x)
      for (int y : {0, 7, 15}) {
        const std::array<int, 3> want =
            i == 2 ? std::array<int, 3>{0, 0, 0}
                   : std::array<int, 3>{colours[static_cast<std::size_t>(i)][0],
                                        colours[static_cast<std::size_t>(i)][1],
                                        colours[static_cast<std::size_t>(i)][2]};
        EXPECT_EQ(at(t.levels[0], x, y), want) << "tile " << i << " x " << x << " y " << y;
      }
}

TEST(TextureDecoder, BytesThatAreNoImageFailWithAMessage) {
  DecodeJob job;
  job.key = {0, 0, 0, 1};
  job.width = 8;
  job.height = 8;
  job.tiles.emplace_back(std::vector<std::byte>(100, std::byte{0x42}));
  const DecodedTexture t = decodeTexture(job);
  EXPECT_FALSE(t.ok);
  EXPECT_NE(t.error.find("neither JPEG nor PNG"), std::string::npos) << t.error;
  auto truncated = twoTone(8, 8, {1, 2, 3}, {4, 5, 6});
  truncated.resize(truncated.size() / 2);
  job.tiles[0] = truncated;
  EXPECT_FALSE(decodeTexture(job).ok);
}

TEST(TextureDecoder, WorkersDecodeEveryJobOnce) {
  TextureDecoder decoder(3);
  const auto png = twoTone(32, 32, {10, 20, 30}, {40, 50, 60});
  std::set<std::int64_t> want;
  for (std::int64_t c = 0; c < 40; ++c) {
    DecodeJob job;
    job.key = {5, 7, c, 1};
    job.width = 32;
    job.height = 32;
    job.tiles.emplace_back(png);
    decoder.submit(std::move(job));
    want.insert(c);
  }
  // Pending until taken back, whether or not a worker has finished it.
  EXPECT_EQ(decoder.pending(), 40u);
  std::set<std::int64_t> got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (got.size() < want.size() && std::chrono::steady_clock::now() < deadline) {
    for (auto& t : decoder.takeDone()) {
      EXPECT_TRUE(t.ok);
      EXPECT_TRUE(got.insert(t.key.col).second) << "decoded twice: " << t.key.col;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(got, want);
  EXPECT_EQ(decoder.pending(), 0u);
}

TEST(TextureDecoder, DestroyedWithJobsQueuedJoinsItsWorkers) {
  const auto png = twoTone(256, 256, {1, 2, 3}, {4, 5, 6});
  auto decoder = std::make_unique<TextureDecoder>(2);
  for (std::int64_t c = 0; c < 50; ++c) {
    DecodeJob job;
    job.key = {8, 1, c, 1};
    job.width = 256;
    job.height = 256;
    job.tiles.emplace_back(png);
    decoder->submit(std::move(job));
  }
  decoder.reset(); // must neither hang nor touch freed memory (ASan/TSan runs)
  SUCCEED();
}

namespace {

/** The nice values of this process's threads (Linux: /proc/self/task/TID/stat, field 19). */
std::vector<int> threadNiceValues() {
  std::vector<int> out;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream in(task.path() / "stat");
    std::string line;
    std::getline(in, line);
    const auto close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream fields(line.substr(close + 1));
    std::string field;
    for (int i = 0; i <= 16 && fields >> field; ++i) {
      if (i == 16) out.push_back(std::stoi(field));
    }
  }
  return out;
}

} // namespace

TEST(TextureDecoder, WorkersRunAtTheNiceValueAskedFor) {
  errno = 0;
  const int base = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  ASSERT_EQ(errno, 0);
  if (base > 14) GTEST_SKIP() << "the test runs at nice " << base;
  const auto before = threadNiceValues();
  const auto count = [](const std::vector<int>& v, int n) {
    return std::count(v.begin(), v.end(), n);
  };
  TextureDecoder decoder(1, 5);
  DecodeJob job;
  job.key = {1, 0, 0, 1};
  job.width = 8;
  job.height = 8;
  job.tiles.emplace_back(twoTone(8, 8, {1, 2, 3}, {4, 5, 6}));
  decoder.submit(std::move(job));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::size_t done = 0;
  while (done == 0 && std::chrono::steady_clock::now() < deadline) {
    done += decoder.takeDone().size();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(done, 1u);
  // The worker has run a job, so it has set its own nice value; the calling thread kept its own.
  EXPECT_EQ(count(threadNiceValues(), base + 5), count(before, base + 5) + 1);
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())), base);
}

// Tiles that are neither JPEG nor PNG (a layer of format image/tiff) go to the ImageDecoder given
// (`tellus` passes the imaging module's, OpenImageIO); JPEG and PNG never do.
TEST(TextureDecoder, OtherFormatsGoToTheImageDecoderWithTheirTypeAndTheTileSize) {
  struct Call {
    std::string type;
    int width, height;
  };
  std::vector<Call> calls;
  const ImageDecoder other = [&](std::span<const std::byte> bytes,
                                 std::string_view type,
                                 int w,
                                 int h) -> std::expected<RgbaImage, std::string> {
    calls.push_back({std::string(type), w, h});
    if (bytes.size() < 4 || bytes[0] != std::byte{'I'}) return std::unexpected("not a TIFF");
    RgbaImage img{w, h, std::vector<std::uint8_t>(static_cast<std::size_t>(w * h * 4), 0)};
    for (std::size_t i = 0; i < img.pixels.size(); i += 4) {
      img.pixels[i + 1] = 180; // green
      img.pixels[i + 3] = 255;
    }
    return img;
  };
  const std::vector<std::byte> tiff = {
      std::byte{'I'}, std::byte{'I'}, std::byte{42}, std::byte{0}, std::byte{8}};
  DecodeJob job;
  job.key = {3, 39, 8, 2}; // a merged node: a TIFF tile west, a PNG tile east
  job.width = 16;
  job.height = 8;
  job.tileWidth = 32;
  job.tileHeight = 16;
  job.tiles.emplace_back(tiff);
  job.tiles.emplace_back(twoTone(32, 16, {200, 0, 0}, {200, 0, 0}));
  job.contentTypes = {"image/tiff", "image/png"};
  const DecodedTexture t = decodeTexture(job, other);
  ASSERT_TRUE(t.ok) << t.error;
  ASSERT_EQ(calls.size(), 1u); // the PNG tile was read here
  EXPECT_EQ(calls[0].type, "image/tiff");
  EXPECT_EQ(calls[0].width, 32);
  EXPECT_EQ(calls[0].height, 16);
  EXPECT_EQ(at(t.levels[0], 2, 3), (std::array<int, 3>{0, 180, 0}));
  EXPECT_EQ(at(t.levels[0], 12, 3), (std::array<int, 3>{200, 0, 0}));
  // Without a decoder such a tile is an error, as before; the decoder's own error is kept.
  DecodeJob one = job;
  one.tiles.resize(1);
  EXPECT_FALSE(decodeTexture(one).ok);
  one.tiles[0] = std::vector<std::byte>(16, std::byte{0x42});
  const DecodedTexture bad = decodeTexture(one, other);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("not a TIFF"), std::string::npos) << bad.error;
  // An answer that is not width x height x 4 bytes is refused, not read past its end.
  const ImageDecoder shortAnswer = [](std::span<const std::byte>,
                                      std::string_view,
                                      int w,
                                      int h) -> std::expected<RgbaImage, std::string> {
    return RgbaImage{w, h, {1, 2, 3}};
  };
  one.tiles[0] = tiff;
  EXPECT_FALSE(decodeTexture(one, shortAnswer).ok);
  // The pool's workers use the decoder it was made with.
  TextureDecoder pool(2, 0, other);
  pool.submit(job);
  std::vector<DecodedTexture> done;
  for (int i = 0; i < 500 && done.empty(); ++i) {
    done = pool.takeDone();
    if (done.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_EQ(done.size(), 1u);
  EXPECT_TRUE(done[0].ok) << done[0].error;
}
