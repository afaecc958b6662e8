#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>

#include <set>
#include <string>

using namespace tellus;

namespace {

void expectSafe(const std::string& encoded) {
  SCOPED_TRACE(encoded);
  ASSERT_FALSE(encoded.empty());
  EXPECT_NE(encoded.front(), '.');
  EXPECT_LE(encoded.size(), kMaxNameComponent);
  for (const char c : encoded) {
    EXPECT_NE(c, '/');
    EXPECT_NE(c, '\\');
    EXPECT_NE(c, '\0');
    EXPECT_GE(static_cast<unsigned char>(c), 0x21);
    EXPECT_LT(static_cast<unsigned char>(c), 0x7f);
  }
}

} // namespace

TEST(TilePath, WorldWindLayoutWithoutPadding) {
  EXPECT_EQ(tileRelativePath(TileKey{0, 0, 0}, "jpg"), "0/0/0_0.jpg");
  EXPECT_EQ(tileRelativePath(TileKey{3, 12, 7}, "png"), "3/12/12_7.png");
  EXPECT_EQ(tileRelativePath(TileKey{30, 9663676415, 19327352831}, "bil"),
            "30/9663676415/9663676415_19327352831.bil");
}

TEST(TilePath, ParseRoundTrip) {
  for (const TileKey k :
       {TileKey{0, 0, 0}, TileKey{5, 31, 17}, TileKey{30, 5368709119, 10737418239}}) {
    std::string ext;
    const auto parsed = parseTileRelativePath(tileRelativePath(k, "jpg"), &ext);
    ASSERT_TRUE(parsed);
    EXPECT_EQ(*parsed, k);
    EXPECT_EQ(ext, "jpg");
  }
}

TEST(TilePath, ParseRejectsEverythingElse) {
  for (const char* bad : {"",
                          "0",
                          "0/0",
                          "0/0/0.jpg",
                          "0/0/0_0",
                          "00/0/0_0.jpg",
                          "0/01/01_0.jpg",
                          "0/1/2_0.jpg",
                          "-1/0/0_0.jpg",
                          "0/-1/-1_0.jpg",
                          "0/0/0_-1.jpg",
                          "31/0/0_0.jpg",
                          "0/0/0_0./x",
                          "0/0/0_99999999999999999999.jpg",
                          "a/0/0_0.jpg",
                          "0/0/0_0x.jpg",
                          "+1/0/0_0.jpg",
                          // negative zero (from_chars takes it; found by fuzz_static_path)
                          "-0/0/0_0.jpg",
                          "0/-0/-0_0.jpg",
                          "5/100/100_-00.b1",
                          "0/0/0_-0.jpg"}) {
    EXPECT_FALSE(parseTileRelativePath(bad)) << bad;
  }
}

TEST(TilePath, NameEncodingCannotEscape) {
  const std::string nul("a\0b", 3);
  for (const std::string& name : {std::string(".."),
                                  std::string("."),
                                  std::string("../../etc/passwd"),
                                  std::string("a/b"),
                                  std::string("a\\b"),
                                  nul,
                                  std::string("\x01\x1f\x7f"),
                                  std::string(".hidden"),
                                  std::string(""),
                                  std::string(400, 'x'),
                                  std::string(400, '/'),
                                  std::string("Blue Marble (2004) – 5.2004"),
                                  std::string("%2e%2e")}) {
    expectSafe(encodeNameComponent(name));
  }
  EXPECT_EQ(encodeNameComponent("bluemarble"), "bluemarble");
  EXPECT_EQ(encodeNameComponent(".."), "%2e.");
  EXPECT_EQ(encodeNameComponent("a/b"), "a%2fb");
  EXPECT_EQ(encodeNameComponent(""), "%");
  EXPECT_EQ(encodeNameComponent(std::string(1, '\0')), "%00");
}

TEST(TilePath, NameEncodingIsInjective) {
  std::set<std::string> seen;
  const std::string names[] = {"a",
                               "A",
                               "a.",
                               ".a",
                               "%2e",
                               "a%",
                               "a/",
                               "a_",
                               "a-",
                               "",
                               "%00",
                               std::string(1, '\0'),
                               std::string(300, 'y'),
                               std::string(301, 'y'),
                               std::string(300, 'y') + "z"};
  for (const auto& n : names)
    EXPECT_TRUE(seen.insert(encodeNameComponent(n)).second) << n;
}

TEST(TilePath, DatasetFolderDependsOnWhatMakesTilesDiffer) {
  DatasetSpec a;
  a.server = "local";
  a.name = "bluemarble";
  a.mimeType = "image/jpeg";
  a.extension = "jpg";
  DatasetSpec b = a;
  EXPECT_EQ(datasetFolder(a), datasetFolder(b));
  EXPECT_TRUE(datasetFolder(a).starts_with("local/bluemarble-"));
  b.time = "2024-01-01";
  EXPECT_NE(datasetFolder(a), datasetFolder(b));
  b = a;
  b.grid.tileWidth = 256;
  EXPECT_NE(datasetFolder(a), datasetFolder(b));
  b = a;
  b.grid.sector.west = -179.0;
  EXPECT_NE(datasetFolder(a), datasetFolder(b));
  b = a;
  b.style = "default";
  EXPECT_NE(datasetFolder(a), datasetFolder(b));
  b = a;
  b.pinned = true; // pinning is policy, not content
  EXPECT_EQ(datasetFolder(a), datasetFolder(b));
}

TEST(TilePath, DescriptorRoundTrip) {
  DatasetSpec a;
  a.server = "gibs\nserver";
  a.name = "sst=\\x";
  a.grid = GridSpec{Sector{-10.5, 20.25, 30.125, 60.0}, 20.0, 150, 150, 12};
  a.mimeType = "application/bil16";
  a.extension = "bil";
  a.time = "2024-06-01";
  a.pinned = true;
  const auto parsed = parseDatasetSpec(serializeDatasetSpec(a));
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->server, a.server);
  EXPECT_EQ(parsed->name, a.name);
  EXPECT_EQ(parsed->grid, a.grid);
  EXPECT_EQ(parsed->time, a.time);
  EXPECT_TRUE(parsed->pinned);
  EXPECT_EQ(datasetFolder(*parsed), datasetFolder(a));
  EXPECT_FALSE(parseDatasetSpec("server=x\n"));
  EXPECT_FALSE(parseDatasetSpec("garbage"));
}
