#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

const fs::path kData = TELLUS_TEST_DATA_DIR;

const LocalRasterSource& blueMarble() {
  static const auto src = LocalRasterSource::open(kData / "bmng_2048x1024.jpg");
  EXPECT_TRUE(src) << (src ? "" : src.error());
  return *src;
}

const LocalRasterSource& etopo() {
  static const auto src = LocalRasterSource::open(kData / "etopo20_int16.tif");
  EXPECT_TRUE(src) << (src ? "" : src.error());
  return *src;
}

/** The bundled COADS sea-surface temperature (January, 0.01 deg C, land -32768; data/README.md). */
const LocalRasterSource& sst() {
  static const auto src = LocalRasterSource::open(kData / "sst_coads_jan_int16.tif");
  EXPECT_TRUE(src) << (src ? "" : src.error());
  return *src;
}

std::int16_t bilAt(const std::vector<std::byte>& bil, int width, int x, int y) {
  const auto i = 2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                      static_cast<std::size_t>(x));
  return static_cast<std::int16_t>(std::to_integer<std::uint16_t>(bil[i]) |
                                   (std::to_integer<std::uint16_t>(bil[i + 1]) << 8));
}

} // namespace

TEST(LocalRasterSource, BundledImageryCoversTheGlobe) {
  const auto& src = blueMarble();
  EXPECT_EQ(src.width(), 2048);
  EXPECT_EQ(src.height(), 1024);
  EXPECT_EQ(src.channels(), 3);
  const Sector c = src.coverage();
  EXPECT_NEAR(c.west, -180.0, 1e-9);
  EXPECT_NEAR(c.east, 180.0, 1e-9);
  EXPECT_NEAR(c.south, -90.0, 1e-9);
  EXPECT_NEAR(c.north, 90.0, 1e-9);
}

TEST(LocalRasterSource, ColoursAreWhereTheEarthPutsThem) {
  const auto& src = blueMarble();
  // Sahara: sand, red above blue. Central Pacific: deep water, blue above red.
  EXPECT_GT(src.sample(23.0, 10.0, 0), src.sample(23.0, 10.0, 2) + 40);
  EXPECT_GT(src.sample(0.0, -140.0, 2), src.sample(0.0, -140.0, 0) + 20);
  // Antarctica: bright ice.
  EXPECT_GT(src.sample(-85.0, 0.0, 0), 180.0);
}

// The bundled Moon and Mars (issue 26, data/README.md): north up, 180 W at the left, features
// where the IAU frames put them.
TEST(LocalRasterSource, TheMoonAndMarsAreWhereTheirFeaturesAre) {
  const auto moon = LocalRasterSource::open(kData / "moon_2048x1024.jpg");
  ASSERT_TRUE(moon) << moon.error();
  EXPECT_EQ(moon->width(), 2048);
  // Tycho's rays (43.3 S, 11.4 W) bright; Mare Imbrium (32.8 N, 15.6 W) and Mare Serenitatis
  // (28 N, 17.5 E) dark; the southern highlands in between.
  const double tycho = moon->sample(-43.31, -11.36, 0);
  const double imbrium = moon->sample(32.8, -15.6, 0);
  const double highlands = moon->sample(-60.0, 0.0, 0);
  EXPECT_GT(tycho, highlands + 30);
  EXPECT_GT(highlands, imbrium + 30);
  EXPECT_LT(moon->sample(28.0, 17.5, 0), highlands - 30);
  const auto mars = LocalRasterSource::open(kData / "mars_512x256.jpg");
  ASSERT_TRUE(mars) << mars.error();
  EXPECT_EQ(mars->width(), 512);
  // Hellas (42.4 S, 70 E) bright and red; Syrtis Major (8.4 N, 69.5 E) dark; the north cap white.
  EXPECT_GT(mars->sample(-42.4, 70.0, 0), mars->sample(8.4, 69.5, 0) + 60);
  EXPECT_GT(mars->sample(-42.4, 70.0, 0), mars->sample(-42.4, 70.0, 2) + 60);
  EXPECT_GT(mars->sample(88.0, 0.0, 2), 180.0);
}

TEST(LocalRasterSource, JpegTileDecodesToTheRightSize) {
  auto tile = blueMarble().renderTile(Sector{-180, -90, -144, -54}, 512, 512, "image/jpeg");
  ASSERT_TRUE(tile) << tile.error();
  ASSERT_GT(tile->size(), 1000u);
  EXPECT_EQ((*tile)[0], std::byte{0xFF});
  EXPECT_EQ((*tile)[1], std::byte{0xD8});
  auto png = blueMarble().renderTile(Sector{-180, -90, -144, -54}, 64, 32, "image/png");
  ASSERT_TRUE(png) << png.error();
  EXPECT_EQ((*png)[1], std::byte{'P'});
  EXPECT_FALSE(blueMarble().renderTile(Sector{-180, -90, -144, -54}, 64, 32, "image/gif"));
  EXPECT_FALSE(blueMarble().renderTile(Sector{0, 0, 0, 0}, 64, 32, "image/png"));
  EXPECT_FALSE(blueMarble().renderTile(Sector{0, 0, 10, 10}, 0, 32, "image/png"));
}

TEST(LocalRasterSource, Bil16HeightsMatchTheSourceData) {
  const auto& src = etopo();
  EXPECT_EQ(src.width(), 1080);
  EXPECT_EQ(src.height(), 540);
  // Level-0 20-degree tile over the Himalaya: 20..40 N, 80..100 E.
  const Sector box{80, 20, 100, 40};
  auto bil = src.renderTile(box, 150, 150, "application/bil16");
  ASSERT_TRUE(bil) << bil.error();
  ASSERT_EQ(bil->size(), 150u * 150u * 2u);
  int maxH = -32768;
  for (int y = 0; y < 150; ++y) {
    for (int x = 0; x < 150; ++x) {
      const int h = bilAt(*bil, 150, x, y);
      maxH = std::max(maxH, h);
      if ((x * 7 + y) % 97 == 0) {
        const double lat = box.north - (y + 0.5) * 20.0 / 150;
        const double lon = box.west + (x + 0.5) * 20.0 / 150;
        EXPECT_EQ(h, static_cast<int>(std::lround(src.sample(lat, lon, 0)))) << x << "," << y;
      }
    }
  }
  EXPECT_GT(maxH, 5000); // Tibet and the Himalaya at 20' resolution
  // The Pacific near the Mariana trench is deep.
  EXPECT_LT(src.sample(11.0, 142.0, 0), -4000.0);
}

// The bundled SST grid: values at its cell centres as GDAL reads them (gdallocationinfo
// -wgs84 data/sst_coads_jan_int16.tif LON LAT), land no data.
TEST(LocalRasterSource, BundledSeaSurfaceTemperature) {
  const auto& src = sst();
  EXPECT_EQ(src.width(), 180);
  EXPECT_EQ(src.height(), 90);
  EXPECT_EQ(src.channels(), 1);
  EXPECT_EQ(src.sampleType(), SampleType::Int16);
  const Sector c = src.coverage();
  EXPECT_NEAR(c.west, -180.0, 1e-9);
  EXPECT_NEAR(c.north, 90.0, 1e-9);
  EXPECT_NEAR(c.east, 180.0, 1e-9);
  EXPECT_NEAR(c.south, -90.0, 1e-9);
  EXPECT_EQ(src.sample(1.0, -159.0, 0, -32768), 2662.0);      // central Pacific, 26.62 C
  EXPECT_EQ(src.sample(1.0, 151.0, 0, -32768), 2939.0);       // the western Pacific warm pool
  EXPECT_EQ(src.sample(1.0, -29.0, 0, -32768), 2704.0);       // equatorial Atlantic
  EXPECT_TRUE(std::isnan(src.sample(23.0, 10.0, 0, -32768))); // the Sahara: no data
}

// Land is no data in the grid: a sample beside a coast takes the nearest sea cell instead of
// mixing -32768 in (1 N: 79 W is sea, 26.30 C; 77 W is Colombia), and a rendered value tile holds
// only no-data and plausible temperatures.
TEST(LocalRasterSource, NoDataIsNeverMixedIn) {
  const auto& src = sst();
  EXPECT_EQ(src.sample(1.0, -78.2, 0, -32768), 2630.0);
  EXPECT_EQ(src.sample(1.0, -77.8, 0, -32768), 2630.0); // nearer the land cell: still the sea's
  EXPECT_LT(src.sample(1.0, -78.2, 0), -10000.0);       // what mixing would give
  // Level 0 over the Pacific coast of South America (36 degrees, 64 px).
  auto bil = src.renderTile(Sector{-108, -18, -72, 18}, 64, 64, "application/bil16", -32768);
  ASSERT_TRUE(bil) << bil.error();
  int sea = 0, land = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const int v = bilAt(*bil, 64, x, y);
      if (v == -32768) {
        ++land;
      } else {
        ++sea;
        EXPECT_TRUE(v > 1500 && v < 3200) << x << "," << y << ": " << v;
      }
    }
  EXPECT_GT(sea, 2000);
  EXPECT_GT(land, 200);
}

TEST(LocalRasterSource, ReadsWorldFilesStrictly) {
  test::TempDir dir("wld");
  EXPECT_FALSE(readWorldFile(dir.path() / "missing.jgw"));
  std::ofstream(dir.path() / "rot.jgw") << "1\n0.1\n0\n-1\n0\n0\n";
  EXPECT_FALSE(readWorldFile(dir.path() / "rot.jgw"));
  std::ofstream(dir.path() / "short.jgw") << "1\n0\n0\n";
  EXPECT_FALSE(readWorldFile(dir.path() / "short.jgw"));
  std::ofstream(dir.path() / "ok.jgw") << "0.5\n0\n0\n-0.5\n-179.75\n89.75\n";
  auto g = readWorldFile(dir.path() / "ok.jgw");
  ASSERT_TRUE(g);
  EXPECT_DOUBLE_EQ(g->west, -180.0);
  EXPECT_DOUBLE_EQ(g->north, 90.0);
  EXPECT_EQ(worldFileFor(dir.path() / "x.jpg").filename(), "x.jgw");
  EXPECT_EQ(worldFileFor(dir.path() / "x.tif").filename(), "x.tfw");
}

TEST(LocalRasterSourceExtremes, PolesAntimeridianAndNonFinite) {
  const auto& src = etopo();
  // lon -180 and 180 are one meridian: the same sample, both as input and as the image's edge.
  EXPECT_EQ(src.sample(10.0, -180.0, 0), src.sample(10.0, 180.0, 0));
  EXPECT_EQ(src.sample(-0.0, -0.0, 0), src.sample(0.0, 0.0, 0));
  EXPECT_FALSE(std::isnan(src.sample(90.0, 0.0, 0)));
  EXPECT_FALSE(std::isnan(src.sample(-90.0, 180.0, 0)));
  EXPECT_GT(src.sample(-90.0, 0.0, 0), 2000.0); // the Antarctic plateau
  EXPECT_TRUE(std::isnan(src.sample(90.0001, 0.0, 0)));
  EXPECT_TRUE(std::isnan(src.sample(NAN, 0.0, 0)));
  EXPECT_TRUE(std::isnan(src.sample(0.0, INFINITY, 0)));
  EXPECT_TRUE(std::isnan(src.sample(0.0, 0.0, 7)));
  EXPECT_FALSE(src.renderTile(Sector{NAN, 0, 10, 10}, 8, 8, "application/bil16"));
  // A tile whose edge is the antimeridian samples across it without a seam.
  auto east = src.renderTile(Sector{160, -20, 180, 0}, 150, 150, "application/bil16");
  auto west = src.renderTile(Sector{-180, -20, -160, 0}, 150, 150, "application/bil16");
  ASSERT_TRUE(east && west);
  for (int y = 0; y < 150; y += 10) {
    EXPECT_NEAR(bilAt(*east, 150, 149, y), bilAt(*west, 150, 0, y), 1500) << y;
  }
}

TEST(SeederIntegration, SeedsResumesAndCountsADryRun) {
  test::TempDir dir("seed");
  auto cache = test::openTestCache(dir.path());
  ASSERT_TRUE(cache);
  DatasetSpec spec;
  spec.server = "local";
  spec.name = "bluemarble";
  spec.grid = GridSpec{Sector{}, 36.0, 128, 128, 3};
  spec.mimeType = "image/jpeg";
  spec.extension = "jpg";
  const auto id = *cache->registerDataset(spec);
  SeedOptions so;
  so.fromLevel = 0;
  so.toLevel = 1;
  so.dryRun = true;
  auto dry = seedFromRaster(*cache, id, blueMarble(), so);
  ASSERT_TRUE(dry);
  EXPECT_EQ(dry->planned, 50 + 200);
  EXPECT_EQ(dry->written, 0);
  EXPECT_EQ(*cache->totalBytes(), 0);
  so.dryRun = false;
  so.box = Sector{-40, -10, 40, 10}; // level 0: 4 columns x 1 row; level 1: 6 x 2
  auto first = seedFromRaster(*cache, id, blueMarble(), so);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->planned, 4 + 12);
  EXPECT_EQ(first->written, first->planned);
  auto second = seedFromRaster(*cache, id, blueMarble(), so);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->skipped, first->planned);
  EXPECT_EQ(second->written, 0);
  auto hit = cache->get(id, TileKey{0, 2, 4});
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->kind, CacheLookup::Kind::Hit);
  EXPECT_EQ(hit->meta.contentType, "image/jpeg");
}

// A value layer seeded from its raster (`tellus seed` of a local layer): the tiles' no-data is
// the layer's (SeedOptions::noData), and the source's land is never mixed into the sea's values.
TEST(SeederIntegration, SeedsValuesWithTheLayersNoData) {
  test::TempDir dir("seed-values");
  auto cache = test::openTestCache(dir.path());
  ASSERT_TRUE(cache);
  DatasetSpec spec;
  spec.server = "local-sst";
  spec.name = "sst";
  spec.grid = GridSpec{Sector{}, 36.0, 64, 64, 1};
  spec.mimeType = "application/bil16";
  spec.extension = "bil";
  const auto id = *cache->registerDataset(spec);
  SeedOptions so;
  so.box = Sector{-108, -18, -72, 18}; // the Pacific coast of South America: tile (0, 2, 2)
  auto report = seedFromRaster(*cache, id, sst(), so);
  ASSERT_TRUE(report);
  EXPECT_EQ(report->written, 1);
  auto hit = cache->get(id, TileKey{0, 2, 2});
  ASSERT_TRUE(hit);
  ASSERT_EQ(hit->bytes.size(), 64u * 64u * 2u);
  int land = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const int v = bilAt(hit->bytes, 64, x, y);
      if (v == -32768)
        ++land;
      else
        EXPECT_TRUE(v > 1500 && v < 3200) << x << "," << y << ": " << v;
    }
  EXPECT_GT(land, 200);
}
