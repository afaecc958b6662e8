// The imaging module loaded on demand: the loader (search order, versions, a missing module), a
// LocalRasterSource that opens without it and decodes on first use, and a process that opens
// rasters and serves cached tiles without loading it (and so without OpenImageIO).

#include "../support/CacheFixtures.hpp"
#include "../support/ImageFiles.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ImagingModule.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/RasterHeader.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/TileValidation.hpp>

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <spawn.h>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

using namespace tellus;
using test::readAll;
using test::writeWithOiio;
namespace fs = std::filesystem;

namespace {

const fs::path kData = TELLUS_TEST_DATA_DIR;
const fs::path kBlueMarble = kData / "bmng_2048x1024.jpg";
const fs::path kEtopo = kData / "etopo20_int16.tif";

/**
 * Runs the current test again in a fresh process (this executable, filtered to the test, with
 * TELLUS_FRESH_PROCESS=1), so that nothing loaded by earlier tests in this process is there; the
 * test's body calls inFreshProcess() first, which in that process runs `body` and exits 0, or
 * prints the failure and exits 1.
 */
template <class F> void inFreshProcess(F&& body) {
  if (std::getenv("TELLUS_FRESH_PROCESS") != nullptr) {
    const std::string failure = body();
    if (!failure.empty())
      std::fprintf(stderr, "FAILED in the fresh process: %s\n", failure.c_str());
    std::fflush(stderr);
    std::exit(failure.empty() ? 0 : 1);
  }
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string filter =
      std::string("--gtest_filter=") + info->test_suite_name() + "." + info->name();
  std::string exe = fs::read_symlink("/proc/self/exe").string();
  std::vector<std::string> env{"TELLUS_FRESH_PROCESS=1"};
  for (char** e = environ; *e; ++e)
    env.emplace_back(*e);
  std::vector<char*> argv{exe.data(), filter.data(), nullptr};
  std::vector<char*> envp;
  for (auto& e : env)
    envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  ASSERT_EQ(::posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), envp.data()), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the fresh process died (status " << status << ")";
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the fresh process failed (its output is above)";
}

bool mapped(const std::string& name) {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    if (line.find(name) != std::string::npos) return true;
  return false;
}

} // namespace

// ---- LocalRasterSource without OpenImageIO at open ----

TEST(LocalRasterSource, KeepsInt16HeightsAsOpenImageIOReadThem) {
  // The values the previous reader got (OpenImageIO read as DOUBLE, times 32767, rounded) are the
  // ones sampled now from int16 storage, at every pixel centre.
  auto src = LocalRasterSource::open(kEtopo);
  ASSERT_TRUE(src) << src.error();
  EXPECT_EQ(src->sampleType(), SampleType::Int16);
  OIIO::attribute("threads", 1);
  auto in = OIIO::ImageInput::open(kEtopo.string());
  ASSERT_TRUE(in);
  in->threads(1);
  const int w = in->spec().width;
  const int h = in->spec().height;
  std::vector<double> raw(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::DOUBLE, raw.data()));
  const auto& g = src->georef();
  int checked = 0;
  for (int y = 0; y < h; y += 7) {
    for (int x = 0; x < w; x += 3) {
      const double expected =
          std::round(raw[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                         static_cast<std::size_t>(x)] *
                     32767.0);
      const double lat = g.north - (y + 0.5) * g.pixelHeightDeg;
      const double lon = g.west + (x + 0.5) * g.pixelWidthDeg;
      ASSERT_NEAR(src->sample(lat, lon, 0), expected, 1e-6) << x << "," << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20000);
}

TEST(LocalRasterSource, PixelsAreDecodedOnFirstUseAndAFailureIsRemembered) {
  test::TempDir dir("lazy");
  const fs::path image = dir.path() / "bm.jpg";
  fs::copy_file(kBlueMarble, image);
  fs::copy_file(kData / "bmng_2048x1024.jgw", dir.path() / "bm.jgw");
  auto src = LocalRasterSource::open(image);
  ASSERT_TRUE(src) << src.error();
  EXPECT_FALSE(src->loaded());
  EXPECT_EQ(src->width(), 2048);
  EXPECT_EQ(src->channels(), 3);
  EXPECT_EQ(src->sampleType(), SampleType::UInt8);
  auto copy = *src; // copies share the pixels
  fs::remove(image);
  auto tile = src->renderTile(Sector{0, 0, 36, 36}, 16, 16, "image/png");
  ASSERT_FALSE(tile);
  EXPECT_NE(tile.error().find("bm.jpg"), std::string::npos) << tile.error();
  fs::copy_file(kBlueMarble, image);
  EXPECT_FALSE(copy.load()); // remembered, also by the copy
  EXPECT_TRUE(std::isnan(copy.sample(0, 0, 0)));
  EXPECT_FALSE(copy.loaded());

  auto again = LocalRasterSource::open(image);
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->load());
  EXPECT_TRUE(again->loaded());
  EXPECT_TRUE(imagingModuleLoaded());
  EXPECT_TRUE(again->renderTile(Sector{0, 0, 36, 36}, 16, 16, "image/png"));
}

TEST(LocalRasterSource, OtherFormatsAreProbedByTheImagingModule) {
  test::TempDir dir("bmp");
  const fs::path image = dir.path() / "tiny.bmp";
  writeWithOiio(image, 36, 18, 3, OIIO::TypeDesc::UINT8);
  std::ofstream(dir.path() / "tiny.wld") << "10\n0\n0\n-10\n-175\n85\n";
  auto header = readRasterHeader(image);
  ASSERT_TRUE(header);
  EXPECT_FALSE(*header);
  auto src = LocalRasterSource::open(image);
  ASSERT_TRUE(src) << src.error();
  EXPECT_TRUE(imagingModuleLoaded());
  EXPECT_EQ(src->width(), 36);
  EXPECT_EQ(src->height(), 18);
  EXPECT_EQ(src->channels(), 3);
  EXPECT_EQ(src->sampleType(), SampleType::UInt8);
  // Pixel (0, 0) of writeWithOiio's pattern is 0, 7, 14; its centre is at (85, -175).
  EXPECT_EQ(src->sample(85.0, -175.0, 0), 0.0);
  EXPECT_EQ(src->sample(85.0, -175.0, 1), 7.0);
  EXPECT_EQ(src->sample(85.0, -175.0, 2), 14.0);
}

// ---- the loader ----

TEST(ImagingModule, LooksWhereItSays) {
  ::unsetenv("TELLUS_IMAGING_MODULE");
  auto candidates = imagingModuleCandidates();
  ASSERT_GE(candidates.size(), 3u);
  EXPECT_EQ(candidates[0].filename(), candidates.back().filename());
  EXPECT_EQ(candidates[1].parent_path().filename(), "tellus");
  EXPECT_TRUE(fs::exists(candidates.back())) << candidates.back();
  EXPECT_TRUE(checkImagingModule(candidates.back()));
  ::setenv("TELLUS_IMAGING_MODULE", "/somewhere/else.so", 1);
  candidates = imagingModuleCandidates();
  ::unsetenv("TELLUS_IMAGING_MODULE");
  ASSERT_EQ(candidates.size(), 1u);
  EXPECT_EQ(candidates[0], "/somewhere/else.so");
}

TEST(ImagingModule, RefusesMissingForeignAndOtherVersions) {
  auto missing = checkImagingModule("/nonexistent/libtellus_imaging.so");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().rfind(
                "cannot load the imaging module /nonexistent/libtellus_imaging.so: ", 0),
            0u)
      << missing.error();
  EXPECT_NE(missing.error().find("No such file"), std::string::npos) << missing.error();
  auto foreign = checkImagingModule("libm.so.6");
  ASSERT_FALSE(foreign);
  EXPECT_NE(foreign.error().find("tellus_imaging_table"), std::string::npos) << foreign.error();
  auto other = checkImagingModule(TELLUS_TEST_FAKE_IMAGING_MODULE);
  ASSERT_FALSE(other);
  EXPECT_NE(other.error().find("version 999"), std::string::npos) << other.error();
}

TEST(ImagingModuleIntegration, AMissingModuleIsAClearErrorWhereItIsNeeded) {
  inFreshProcess([]() -> std::string {
    ::setenv("TELLUS_IMAGING_MODULE", "/nonexistent/libtellus_imaging.so", 1);
    const std::string expected =
        "cannot load the imaging module /nonexistent/libtellus_imaging.so: ";
    // JPEG and 8-bit PNG are the proxy's own (libjpeg-turbo, libpng): no module needed.
    const std::uint8_t px[3] = {1, 2, 3};
    auto jpeg = encodeImage("image/jpeg", 1, 1, 3, px);
    if (!jpeg) return "encodeImage JPEG without the module: " + jpeg.error();
    if (!encodeImage("image/png", 1, 1, 3, px)) return "encodeImage PNG without the module";
    std::vector<std::uint8_t> back;
    if (!decodeImageryInto(*jpeg, "image/jpeg", 1, 1, back)) return "decode JPEG";
    // TIFF needs it.
    const std::int16_t h1[1] = {7};
    auto tiff = encodeHeights("image/tiff", 1, 1, h1);
    if (tiff || tiff.error().find(expected) != 0)
      return "encodeHeights TIFF: " + (tiff ? std::string("succeeded") : tiff.error());
    // A blank map is the proxy's own too; only INIMAGE's text is drawn by the module.
    if (auto blank = blankMap(MapFormat::Png, false, 4, 4, std::nullopt, false); !blank)
      return "blankMap without text: " + blank.error();
    auto drawn = blankMap(MapFormat::Png, false, 4, 4, std::nullopt, false, "text");
    if (drawn || drawn.error().find(expected) != 0) return "blankMap with text";
    // BIL16 needs no module.
    const std::int16_t heights[1] = {42};
    if (!encodeHeights("application/bil16", 1, 1, heights)) return "bil16";
    // Opening a JPEG/TIFF raster needs none either; its first tile does.
    auto src = LocalRasterSource::open(kBlueMarble);
    if (!src) return "open: " + src.error();
    auto tile = src->renderTile(Sector{0, 0, 36, 36}, 8, 8, "image/jpeg");
    if (tile || tile.error().find(expected) == std::string::npos)
      return "renderTile: " + (tile ? std::string("succeeded") : tile.error());
    // Validating a fetched JPEG is the proxy's own work; a TIFF needs the module.
    FetchResponse r;
    r.status = 200;
    r.contentType = "image/jpeg";
    r.body = readAll(kBlueMarble);
    if (auto v = validateTile(r, "image/jpeg", 2048, 1024); !v)
      return "validateTile JPEG without the module: " + v.error();
    r.contentType = "image/tiff";
    r.body = readAll(kEtopo);
    auto v = validateTile(r, "image/tiff", 1080, 540);
    if (v || v.error().find(expected) == std::string::npos)
      return "validateTile TIFF: " + (v ? std::string("succeeded") : v.error());
    auto loaded = loadImagingModule();
    if (loaded || loaded.error().find(expected) != 0) return "loadImagingModule";
    if (imagingModuleLoaded()) return "loaded after all";
    return {};
  });
}

TEST(ImagingModuleIntegration, OpeningRastersAndServingCachedTilesDoNotLoadIt) {
  inFreshProcess([]() -> std::string {
    ::unsetenv("TELLUS_IMAGING_MODULE");
    if (imagingModuleLoaded() || mapped("libtellus_imaging")) return "loaded at start";
    test::TempDir dir("lazyserve");
    std::string failure;
    {
      auto cache = test::openTestCache(dir.path());
      if (!cache) return "cache";
      Fetcher fetcher;
      UpstreamSpec bm;
      bm.name = "local";
      bm.type = UpstreamSpec::Type::Local;
      bm.path = kBlueMarble;
      UpstreamSpec et = bm;
      et.name = "local-etopo";
      et.path = kEtopo;
      LayerSpec imagery;
      imagery.name = "bluemarble";
      imagery.upstream = "local";
      imagery.dataset.grid = GridSpec{Sector{}, 36.0, 64, 64, 3};
      imagery.dataset.mimeType = "image/jpeg";
      LayerSpec heights;
      heights.name = "etopo";
      heights.upstream = "local-etopo";
      heights.elevation = true;
      heights.dataset.grid = GridSpec{Sector{}, 20.0, 32, 32, 3};
      heights.dataset.mimeType = "application/bil16";
      auto service =
          TileService::create(*cache, fetcher, {bm, et}, {imagery, heights}, TileServiceOptions{});
      if (!service) return "TileService::create: " + service.error();
      if (imagingModuleLoaded() || mapped("libtellus_imaging"))
        return "opening the rasters loaded the imaging module";
      // A tile already in the cache is answered from it.
      auto spec = (*service)->describe("bluemarble");
      if (!spec) return "describe";
      auto id = cache->registerDataset(*spec);
      if (!id) return "registerDataset";
      const auto cached = test::payload(TileKey{0, 2, 5});
      if (!cache->put(*id, TileKey{0, 2, 5}, cached, TileMeta{})) return "put";
      auto get = [&](const TileKey& key) {
        std::promise<TileAnswer> p;
        auto f = p.get_future();
        (*service)->getTile(
            "bluemarble", "", key, [&p](TileAnswer&& a) { p.set_value(std::move(a)); });
        return f.get();
      };
      const TileAnswer hit = get(TileKey{0, 2, 5});
      // A hit holds the cached file open (for sendfile) rather than its bytes.
      const auto hitBytes =
          hit.file ? hit.file->readAll().value_or(std::vector<std::byte>{}) : hit.bytes;
      if (hit.kind != TileAnswer::Kind::Tile || hit.origin != TileOrigin::Hit || hitBytes != cached)
        return "the cached tile was not a hit: " + hit.message;
      if (imagingModuleLoaded() || mapped("libtellus_imaging"))
        return "a cache hit loaded the imaging module";
      // A miss from a local raster is rendered: now the module (and OpenImageIO) is there.
      const TileAnswer miss = get(TileKey{0, 0, 0});
      if (miss.kind != TileAnswer::Kind::Tile || miss.origin != TileOrigin::Miss)
        return "the miss was not rendered: " + miss.message;
      if (sniff(miss.bytes) != ImageKind::Jpeg) return "the miss is not a JPEG";
      // (OpenImageIO itself is mapped from the start here: this test executable links it.)
      if (!imagingModuleLoaded() || !mapped("libtellus_imaging"))
        return "the miss did not load the imaging module";
    }
    return failure;
  });
}
