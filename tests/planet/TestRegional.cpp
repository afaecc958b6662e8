// Several datasets as one layer (issue #7, thesis 4.6.3): the smallest covering dataset serves
// each tile; elsewhere the tile is absent, so the number of levels differs by region.

#include "../support/FakeTileSource.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/RegionalSource.hpp>

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

namespace tellus::planet {
namespace {

using tellus::test::FakeTileSource;

/** Datasets with fixed grids, every tile a byte of "image/png" (Ok). */
void world(FakeTileSource& d) {
  const auto layer = [&](const std::string& name, GridSpec grid) {
    d.addLayer({name, grid, "image/png", FakeTileSource::bytes({std::byte{1}}, "image/png")});
  };
  layer("global", GridSpec{Sector{}, 36.0, 512, 512, 3});
  // A regional dataset over the Alps (inside one level-1 tile), levels 0-7, and a smaller one
  // inside it with levels 0-9.
  layer("alps", GridSpec{Sector{4.5, 43.2, 16.2, 48.6}, 36.0, 512, 512, 8});
  layer("valley", GridSpec{Sector{7.0, 45.5, 8.0, 46.2}, 36.0, 512, 512, 10});
  layer("other-grid", GridSpec{Sector{}, 20.0, 150, 150, 5});
}

TEST(RegionalSource, SmallestCoveringDatasetWinsAndLevelsDifferByRegion) {
  FakeTileSource inner;
  world(inner);
  auto made = RegionalTileSource::create(inner, {{"imagery", {"global", "alps", "valley"}}});
  ASSERT_TRUE(made.has_value()) << made.error();
  RegionalTileSource& src = **made;
  const auto spec = src.describe("imagery", "2024-01-01");
  ASSERT_TRUE(spec.has_value());
  EXPECT_EQ(spec->name, "imagery");
  EXPECT_EQ(spec->time, "2024-01-01");
  EXPECT_EQ(spec->grid.numLevels, 10); // the deepest dataset's levels
  EXPECT_EQ(spec->grid.sector, Sector{});
  const TileGrid grid = *TileGrid::create(spec->grid);
  const auto at = [&](double lat, double lon, int level) { return *grid.keyAt(lat, lon, level); };
  // Level 0 tiles are larger than any regional dataset: the global one serves them.
  EXPECT_EQ(src.datasetFor("imagery", at(45.8, 7.5, 0)), "global");
  // Deep over the valley: the valley; over the Alps outside the valley: the Alps.
  EXPECT_EQ(src.datasetFor("imagery", at(45.8, 7.5, 9)), "valley");
  EXPECT_EQ(src.datasetFor("imagery", at(47.0, 12.0, 6)), "alps");
  // Level 2 over the Alps: 9-degree tiles; the one holding (45.8, 7.5) spans 0-9E, 45-54N and is
  // not inside the Alps' sector: the global dataset serves it.
  EXPECT_EQ(src.datasetFor("imagery", at(45.8, 7.5, 2)), "global");
  // Past the global levels, away from every regional dataset: nothing (absent).
  EXPECT_EQ(src.datasetFor("imagery", at(0.0, 0.0, 5)), std::nullopt);
  // A tile straddling the Alps' edge at a level the global dataset lacks: none covers it whole.
  EXPECT_EQ(src.datasetFor("imagery", at(43.2, 10.0, 5)), std::nullopt);
  // Past the deepest level of the valley: nothing.
  EXPECT_EQ(src.datasetFor("imagery", TileKey{10, 0, 0}), std::nullopt);
  // Other layers pass through.
  EXPECT_EQ(src.datasetFor("global", at(45.8, 7.5, 9)), "global");
}

TEST(RegionalSource, RequestsGoToTheWinnerAndUncoveredTilesAreAbsentAtOnce) {
  FakeTileSource inner;
  world(inner);
  inner.setDelivery(FakeTileSource::Delivery::Held); // answered below, or cancelled
  auto src = std::move(*RegionalTileSource::create(inner, {{"imagery", {"global", "alps"}}}));
  const TileGrid grid = *TileGrid::create(
      *src->describe("imagery").transform([](const DatasetSpec& d) { return d.grid; }));
  std::vector<TileStatus> got;
  const auto ask = [&](const TileKey& k) {
    return src->request({"imagery", "t", k}, 1.0, [&](TileResult&& r) { got.push_back(r.status); });
  };
  const TileRequestId a = ask(*grid.keyAt(47.0, 12.0, 6));
  auto asked = inner.requests();
  ASSERT_EQ(asked.size(), 1u);
  EXPECT_EQ(asked[0].address.layer, "alps");
  EXPECT_EQ(asked[0].address.time, "t");
  const TileRequestId b = ask(*grid.keyAt(0.0, 0.0, 6));
  EXPECT_EQ(inner.requestCount(), 1u); // not forwarded
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], TileStatus::Absent);
  // Cancelling reaches the inner request; the absent answer cannot be cancelled (it was called).
  EXPECT_TRUE(src->cancel(a));
  ASSERT_EQ(inner.cancelled().size(), 1u);
  EXPECT_EQ(inner.cancelled()[0], 1u);
  EXPECT_FALSE(src->cancel(b));
  EXPECT_EQ(inner.cancelled().size(), 1u);
  // The inner source's answer reaches the caller; answered, it cannot be cancelled.
  const TileRequestId c = ask(*grid.keyAt(47.0, 12.0, 6));
  EXPECT_EQ(inner.release(), 1u);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[1], TileStatus::Ok);
  EXPECT_FALSE(src->cancel(c));
  EXPECT_EQ(inner.cancelled().size(), 1u);
}

TEST(RegionalSource, RefusesBadCombinations) {
  FakeTileSource inner;
  world(inner);
  EXPECT_FALSE(RegionalTileSource::create(inner, {{"x", {}}}).has_value());
  EXPECT_FALSE(RegionalTileSource::create(inner, {{"x", {"nope"}}}).has_value());
  const auto grids = RegionalTileSource::create(inner, {{"x", {"global", "other-grid"}}});
  ASSERT_FALSE(grids.has_value());
  EXPECT_NE(grids.error().find("another grid"), std::string::npos) << grids.error();
  // A combined layer must not hide another layer of the source.
  EXPECT_FALSE(RegionalTileSource::create(inner, {{"alps", {"global", "valley"}}}).has_value());
  // It may take the name of its own (global) dataset.
  EXPECT_TRUE(RegionalTileSource::create(inner, {{"global", {"global", "alps"}}}).has_value());
  EXPECT_FALSE(RegionalTileSource::create(inner, {{"x", {"global"}}, {"x", {"alps"}}}).has_value());
}

} // namespace
} // namespace tellus::planet
