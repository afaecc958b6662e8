#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <cstdlib>

using namespace tellus;

namespace {
const std::filesystem::path kData = TELLUS_TEST_DATA_DIR;
}

TEST(Config, EmbeddedDefaultIsValidAndServesTheBundledData) {
  const Config c = embeddedDefault(kData, "/tmp/cache");
  ASSERT_TRUE(validate(c)) << validate(c).error();
  ASSERT_NE(c.layer("bluemarble"), nullptr);
  ASSERT_NE(c.layer("etopo"), nullptr);
  EXPECT_EQ(c.layer("nope"), nullptr);
  EXPECT_EQ(c.layer("bluemarble")->dataset.grid.levelZeroDeltaDeg, 36.0);
  EXPECT_EQ(c.layer("etopo")->dataset.grid.levelZeroDeltaDeg, 20.0);
  EXPECT_EQ(c.layer("etopo")->dataset.grid.tileWidth, 150);
  EXPECT_EQ(c.layer("etopo")->dataset.mimeType, "application/bil16");
  EXPECT_TRUE(c.layer("bluemarble")->dataset.pinned);
  EXPECT_EQ(c.cache.root, "/tmp/cache");
}

TEST(Config, ValidationNamesTheLayerAndTheField) {
  Config c = embeddedDefault(kData, "/tmp/cache");
  Config dup = c;
  dup.layers.push_back(dup.layers[0]);
  ASSERT_FALSE(validate(dup));
  EXPECT_NE(validate(dup).error().find("'bluemarble'"), std::string::npos);
  Config grid = c;
  grid.layers[1].dataset.grid.levelZeroDeltaDeg = 7.0;
  ASSERT_FALSE(validate(grid));
  EXPECT_NE(validate(grid).error().find("'etopo'"), std::string::npos);
  Config fmt = c;
  fmt.layers[0].dataset.mimeType = "image/bmp";
  ASSERT_FALSE(validate(fmt));
  EXPECT_NE(validate(fmt).error().find("format"), std::string::npos);
  Config missing = embeddedDefault("/nonexistent", "/tmp/cache");
  ASSERT_FALSE(validate(missing));
  EXPECT_NE(validate(missing).error().find("does not exist"), std::string::npos);
  Config unnamed = c;
  unnamed.layers[0].name.clear();
  EXPECT_FALSE(validate(unnamed));
}

TEST(Config, DefaultCacheRootFollowsTheEnvironment) {
  ::setenv("TELLUS_CACHE", "/srv/tellus", 1);
  EXPECT_EQ(defaultCacheRoot(), "/srv/tellus");
  ::unsetenv("TELLUS_CACHE");
  ::setenv("XDG_CACHE_HOME", "/x", 1);
  EXPECT_EQ(defaultCacheRoot(), "/x/tellus");
  ::unsetenv("XDG_CACHE_HOME");
  ::setenv("HOME", "/home/u", 1);
  EXPECT_EQ(defaultCacheRoot(), "/home/u/.cache/tellus");
}
