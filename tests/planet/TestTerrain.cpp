// Heights on the quadtree (issue #6): the height function over held elevation tiles, and node
// meshes whose edges meet exactly (same level) or lie on the coarser neighbour's chords (levels
// apart), with the zero-area triangles that close the T-junctions.
#include "../support/FakeTileSource.hpp"
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>

namespace tellus::planet {
namespace {

TileGrid elevationGrid(int tileSize = 8, int levels = 6) {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 20.0;
  spec.tileWidth = spec.tileHeight = tileSize;
  spec.numLevels = levels;
  return *TileGrid::create(spec);
}

/** A tile whose samples are a known function of their cell centres' lat/lon. */
template <class F> HeightTile tileOf(const TileGrid& g, const TileKey& k, F f) {
  const Sector s = g.sectorOf(k);
  const int w = g.spec().tileWidth, h = g.spec().tileHeight;
  std::vector<double> raw;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double lat = s.north - (y + 0.5) * (s.north - s.south) / h;
      const double lon = s.west + (x + 0.5) * (s.east - s.west) / w;
      raw.push_back(f(lat, lon));
    }
  return *heightTileFromSamples(k, w, h, raw, {});
}

std::vector<TileKey> keys(const TileGrid& g, const Sector& s, int level) {
  auto k = g.keysCovering(s, level);
  return k ? *k : std::vector<TileKey>{};
}

double planar(double lat, double lon) {
  return 100.0 + 3.0 * lat + 2.0 * lon;
}

TEST(HeightField, EmptyIsSeaLevelAndBadInputIsNan) {
  HeightField f(elevationGrid());
  EXPECT_EQ(f.heightAt(10, 20), 0.0);
  EXPECT_EQ(f.levelAt(10, 20), -1);
  EXPECT_TRUE(std::isnan(f.heightAt(std::nan(""), 0)));
  EXPECT_TRUE(std::isnan(f.heightAt(0, std::numeric_limits<double>::infinity())));
}

TEST(HeightField, BilinearIsExactForAPlaneAcrossHeldNeighbours) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  // All level-1 tiles around (5, 5): a plane is reproduced exactly by bilinear sampling, also
  // across tile borders (taps read the neighbour tile).
  for (const TileKey& k : keys(g, {-20, -20, 20, 20}, 1))
    ASSERT_TRUE(f.insert(tileOf(g, k, planar)));
  for (double lat : {-7.3, 0.0, 0.3, 9.99, 10.0, 10.01})
    for (double lon : {-9.9, 0.0, 0.2, 10.0, 10.04})
      EXPECT_NEAR(f.heightAt(lat, lon), planar(lat, lon), 1e-3) << lat << "," << lon;
  EXPECT_EQ(f.levelAt(1, 1), 1);
}

TEST(HeightField, DeepestHeldLevelWinsAndAncestorsFillIn) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  for (const TileKey& k : keys(g, {-180, -90, 180, 90}, 0))
    f.insert(tileOf(g, k, [](double, double) { return 10.0; }));
  const TileKey deep = *g.keyAt(45.1, 7.1, 3);
  f.insert(tileOf(g, deep, [](double, double) { return 500.0; }));
  EXPECT_EQ(f.heightAt(45.1, 7.1), 500.0);
  EXPECT_EQ(f.levelAt(45.1, 7.1), 3);
  EXPECT_EQ(f.heightAt(-30, 100), 10.0); // level 0 elsewhere
  EXPECT_EQ(f.levelAt(-30, 100), 0);
}

TEST(HeightFieldExtremes, PolesAntimeridianAndNegativeZero) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  for (const TileKey& k : keys(g, {-180, -90, 180, 90}, 0))
    f.insert(tileOf(g, k, [](double lat, double lon) { return lat * 7.0 + lon; }));
  // A pole is one point whatever the longitude.
  const double north = f.heightAt(90, 0);
  for (double lon : {-180.0, -179.0, -0.0, 33.0, 180.0, 540.0})
    EXPECT_EQ(f.heightAt(90, lon), north) << lon;
  EXPECT_EQ(f.heightAt(95, 3), north); // clamped
  EXPECT_EQ(f.heightAt(-90, 10), f.heightAt(-90, -170));
  // -180 and 180 are one meridian; -0.0 is 0; wraps.
  for (double lat : {-89.9, -45.0, 0.0, 12.5, 89.99})
    EXPECT_EQ(f.heightAt(lat, 180.0), f.heightAt(lat, -180.0)) << lat;
  EXPECT_EQ(f.heightAt(-0.0, -0.0), f.heightAt(0.0, 0.0));
  EXPECT_EQ(f.heightAt(10, 370), f.heightAt(10, 10));
  // Continuous across the antimeridian: the taps wrap to the other side's tile.
  EXPECT_NEAR(f.heightAt(10, 179.999), f.heightAt(10, -179.999), 1.0);
}

TEST(HeightField, ChangedSinceCoversTheTileAndItsBilinearReach) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  const std::uint64_t g0 = f.generation();
  f.insert(tileOf(g, {1, 4, 9}, planar)); // -50..-40 N, -90..-80 E
  const Sector s = g.sectorOf({1, 4, 9});
  EXPECT_TRUE(f.changedSince(g0, s));
  EXPECT_TRUE(f.changedSince(g0, {s.east + 0.5, s.south, s.east + 5, s.north})); // one sample away
  EXPECT_FALSE(f.changedSince(g0, {s.east + 5, s.south, s.east + 9, s.north}));
  EXPECT_FALSE(f.changedSince(f.generation(), s));
  const auto [lo, hi] = f.rangeOver(s);
  for (double lat = s.south; lat <= s.north; lat += 0.5)
    for (double lon = s.west; lon <= s.east; lon += 0.5) {
      EXPECT_LE(lo, f.heightAt(lat, lon));
      EXPECT_GE(hi, f.heightAt(lat, lon));
    }
}

TEST(HeightField, LevelForSpacing) {
  HeightField f(elevationGrid(150, 5)); // 20 / 150 = 0.133 deg at level 0
  EXPECT_EQ(f.levelForSpacing(1.0), 0);
  EXPECT_EQ(f.levelForSpacing(0.1), 1);  // 0.0667 <= 0.1
  EXPECT_EQ(f.levelForSpacing(1e-9), 4); // deepest
}

TEST(HeightField, Bil16DecodesLittleEndianWithScaleOffsetAndNoData) {
  const std::vector<std::byte> bytes{std::byte{0x10},
                                     std::byte{0x27}, // 10000
                                     std::byte{0x00},
                                     std::byte{0x80}, // -32768: no data
                                     std::byte{0xFF},
                                     std::byte{0xFF}, // -1
                                     std::byte{0x00},
                                     std::byte{0x00}};
  HeightEncoding enc;
  enc.scale = 0.5;
  enc.offset = 1.0;
  enc.noData = -32768;
  const auto t = decodeBil16({0, 0, 0}, 2, 2, bytes, enc);
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->metres, (std::vector<float>{5001.0f, 0.0f, 0.5f, 1.0f}));
  EXPECT_EQ(t->minM, 0.0f);
  EXPECT_EQ(t->maxM, 5001.0f);
  EXPECT_FALSE(decodeBil16({0, 0, 0}, 2, 2, std::span(bytes).first(6), enc).has_value());
}

// --- meshes ---

const Geodesy& wgs84() {
  static const Geodesy g;
  return g;
}

double bumpy(double lat, double lon) {
  return 3000.0 * std::sin(lat * 0.7) * std::cos(lon * 1.3) + 40.0 * lat;
}

TEST(TerrainMesh, DisplacesAlongTheNormalAndKeepsHeightRange) {
  const Sector s{5.625, 45.0, 7.03125, 46.40625};
  const auto mesh = buildTerrainMesh(wgs84(), s, 17, bumpy, {});
  ASSERT_EQ(mesh.vertices.size(), 17u * 17u);
  EXPECT_EQ(mesh.zeroAreaTriangles, 0u);
  EXPECT_EQ(mesh.indices.size(), 16u * 16u * 6u);
  EXPECT_EQ(mesh.quadrantStart[4], mesh.indices.size());
  for (int r = 0; r < 17; r += 4)
    for (int c = 0; c < 17; c += 4) {
      const double lat = edgeLerp(s.south, s.north, r, 17), lon = edgeLerp(s.west, s.east, c, 17);
      const Ecef e = wgs84().toEcef(lat, lon, bumpy(lat, lon));
      const auto& v = mesh.vertices[static_cast<std::size_t>(r * 17 + c)];
      EXPECT_EQ(v.position, glm::dvec3(e.x, e.y, e.z));
      const Ecef up = wgs84().surfaceNormal(lat, lon);
      EXPECT_GT(glm::dot(glm::dvec3(v.normal), glm::dvec3(up.x, up.y, up.z)), 0.8);
      EXPECT_NEAR(glm::length(glm::dvec3(v.normal)), 1.0, 1e-6);
    }
  EXPECT_LE(mesh.minHeightM, mesh.maxHeightM);
}

TEST(TerrainMesh, SameLevelNeighboursShareEdgeVerticesBitForBit) {
  const TileGrid g = test::globalGrid();
  for (const TileKey k : {TileKey{5, 20, 40}, TileKey{3, 0, 79}, TileKey{4, 79, 0}}) {
    const Sector a = g.sectorOf(k);
    for (const Direction d : {Direction::East, Direction::North}) {
      const auto nk = g.neighbour(k, d);
      if (!nk) continue;
      const Sector b = g.sectorOf(*nk);
      const auto ma = buildTerrainMesh(wgs84(), a, 9, bumpy, {});
      const auto mb = buildTerrainMesh(wgs84(), b, 9, bumpy, {});
      for (int i = 0; i < 9; ++i) {
        const auto& va = d == Direction::East ? ma.vertices[static_cast<std::size_t>(i * 9 + 8)]
                                              : ma.vertices[static_cast<std::size_t>(8 * 9 + i)];
        const auto& vb = d == Direction::East ? mb.vertices[static_cast<std::size_t>(i * 9)]
                                              : mb.vertices[static_cast<std::size_t>(i)];
        EXPECT_EQ(va.position, vb.position) << k.level << "/" << k.row << "/" << k.col << " side "
                                            << static_cast<int>(d) << " i " << i;
      }
    }
  }
}

/** Distance from p to the polyline through pts. */
double toPolyline(const glm::dvec3& p, const std::vector<glm::dvec3>& pts) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    const glm::dvec3 ab = pts[i + 1] - pts[i];
    const double t = std::clamp(glm::dot(p - pts[i], ab) / glm::dot(ab, ab), 0.0, 1.0);
    best = std::min(best, glm::length(p - (pts[i] + ab * t)));
  }
  return best;
}

class EdgeFixing : public ::testing::TestWithParam<int> {}; // levels apart

TEST_P(EdgeFixing, FinerEdgeLiesOnTheCoarseChordsAndZeroAreaTrianglesCloseIt) {
  const int apart = GetParam();
  const TileGrid g = test::globalGrid();
  const int n = 9;
  // A coarse node, and a finer node east of it touching its east edge (the finer node's west
  // side adapts), also one at the coarse edge's north end.
  const TileKey coarseKey{6, 140, 300};
  const Sector coarse = g.sectorOf(coarseKey);
  const auto coarseMesh = buildTerrainMesh(wgs84(), coarse, n, bumpy, {});
  std::vector<glm::dvec3> coarseEdge;
  for (int i = 0; i < n; ++i)
    coarseEdge.push_back(coarseMesh.vertices[static_cast<std::size_t>(i * n + n - 1)].position);
  const std::int64_t f = std::int64_t{1} << apart;
  for (const std::int64_t sub : {std::int64_t{0}, f / 2, f - 1}) {
    const TileKey fineKey{6 + apart, 140 * f + sub, 301 * f};
    const Sector fine = g.sectorOf(fineKey);
    std::array<EdgeAdapt, 4> edges{};
    edges[static_cast<std::size_t>(Direction::West)] = {true, coarse, {}};
    const auto fixed = buildTerrainMesh(wgs84(), fine, n, bumpy, edges);
    const auto plain = buildTerrainMesh(wgs84(), fine, n, bumpy, {});
    double before = 0.0;
    for (int i = 0; i < n; ++i) {
      const auto& v = fixed.vertices[static_cast<std::size_t>(i * n)];
      EXPECT_LT(toPolyline(v.position, coarseEdge), 1e-6)
          << "apart " << apart << " sub " << sub << " i " << i;
      before = std::max(
          before, toPolyline(plain.vertices[static_cast<std::size_t>(i * n)].position, coarseEdge));
    }
    EXPECT_GT(before, 1e-3); // without the fix the edges would not meet
    // Every coarse vertex inside the fine edge is a fine vertex, bit for bit.
    for (const auto& cv : coarseEdge)
      for (int i = 0; i < n; ++i)
        if (glm::length(cv - fixed.vertices[static_cast<std::size_t>(i * n)].position) < 1e-6) {
          EXPECT_EQ(cv, fixed.vertices[static_cast<std::size_t>(i * n)].position);
        }
    // The fans: zero area (collinear), and their outer edges are coarse edge segments.
    EXPECT_GT(fixed.zeroAreaTriangles, 0u);
    std::size_t fans = 0;
    for (std::size_t q = 0; q < 4; ++q) {
      // The fan triangles follow the grid cells in each quadrant range.
      const std::size_t cells =
          static_cast<std::size_t>((n - 1) / 2) * static_cast<std::size_t>((n - 1) / 2) * 6;
      for (std::size_t i = fixed.quadrantStart[q] + cells; i < fixed.quadrantStart[q + 1]; i += 3) {
        const glm::dvec3 a = fixed.vertices[fixed.indices[i]].position;
        const glm::dvec3 b = fixed.vertices[fixed.indices[i + 1]].position;
        const glm::dvec3 c = fixed.vertices[fixed.indices[i + 2]].position;
        EXPECT_LT(glm::length(glm::cross(b - a, c - a)), 1e-3 * glm::length(b - a) + 1e-6);
        EXPECT_LT(toPolyline(a, coarseEdge), 1e-6);
        ++fans;
      }
    }
    EXPECT_EQ(fans, fixed.zeroAreaTriangles);
    // Each fan's apex and last vertex are coarse vertices: the segment from one to the other
    // covers the fine chain completely.
  }
}

INSTANTIATE_TEST_SUITE_P(LevelsApart, EdgeFixing, ::testing::Values(1, 2, 3, 5, 7));

TEST(TerrainMeshExtremes, PoleRowIsOnePointAndAntimeridianEdgesMeet) {
  const TileGrid g = test::globalGrid();
  const auto top = buildTerrainMesh(wgs84(), g.sectorOf({3, 39, 5}), 9, bumpy, {});
  for (int c = 1; c < 9; ++c)
    EXPECT_EQ(top.vertices[static_cast<std::size_t>(8 * 9 + c)].position,
              top.vertices[8 * 9].position);
  for (const auto& v : top.vertices) {
    EXPECT_TRUE(std::isfinite(v.position.x) && std::isfinite(v.position.y) &&
                std::isfinite(v.position.z));
    EXPECT_TRUE(std::isfinite(v.normal.x) && std::isfinite(v.normal.y) &&
                std::isfinite(v.normal.z));
  }
  // West edge at -180 and east edge at 180 of the same row: the same points.
  HeightField f(elevationGrid());
  for (const TileKey& k : keys(f.grid(), {-180, -90, 180, 90}, 0))
    f.insert(tileOf(f.grid(), k, [](double lat, double lon) { return lat * 5 + lon; }));
  const auto h = [&](double lat, double lon) { return f.heightAt(lat, lon); };
  const auto west = buildTerrainMesh(wgs84(), g.sectorOf({4, 50, 0}), 9, h, {});
  const auto east = buildTerrainMesh(wgs84(), g.sectorOf({4, 50, 159}), 9, h, {});
  for (int r = 0; r < 9; ++r) {
    const auto& a = west.vertices[static_cast<std::size_t>(r * 9)].position;
    const auto& b = east.vertices[static_cast<std::size_t>(r * 9 + 8)].position;
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.z, b.z);
    EXPECT_EQ(std::abs(a.y), std::abs(b.y)); // +-0
    EXPECT_LT(std::abs(a.y), 1e-6);
  }
}

TEST(TerrainMeshExtremes, DeepestLevelCornersDistinct) {
  const TileGrid g = test::globalGrid();
  const TileKey k = *g.keyAt(27.98, 86.92, 24); // Everest, level 24: tiles about 0.2 m
  const auto mesh =
      buildTerrainMesh(wgs84(), g.sectorOf(k), 9, [](double, double) { return 8848.0; }, {});
  const auto& v = mesh.vertices;
  EXPECT_GT(glm::length(v[0].position - v[8].position), 0.05);
  EXPECT_GT(glm::length(v[0].position - v[72].position), 0.05);
  EXPECT_GT(glm::length(v[1].position - v[0].position), 0.005);
}

} // namespace
} // namespace tellus::planet

// --- height streaming ---

namespace tellus::planet {
namespace {

using tellus::test::FakeTileSource;

/** Height tiles of a grid, held until the test answers them (in any order). */
void heldHeights(FakeTileSource& src, GridSpec grid) {
  src.addLayer({"h", grid, "application/bil16", {}});
  src.setDelivery(FakeTileSource::Delivery::Held);
}

/** A BIL16 answer of `bytes` zero bytes. */
TileResult bil16(TileStatus status, std::size_t bytes = 0) {
  return FakeTileSource::result(status, std::vector<std::byte>(bytes), "application/bil16");
}

TEST(HeightStreamer, RequestsInOrderWithinTheWindowCancelsAndRetries) {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 20.0;
  spec.tileWidth = spec.tileHeight = 4;
  spec.numLevels = 4;
  const TileGrid grid = *TileGrid::create(spec);
  FakeTileSource src;
  heldHeights(src, spec);
  HeightStreamParams p;
  p.layer = "h";
  p.maxInFlight = 3;
  p.retryAfterS = 5.0;
  HeightStreamer hs(src, grid, p);
  HeightField field(grid);
  const std::vector<TileKey> wish{{0, 4, 9}, {1, 9, 18}, {2, 18, 36}, {3, 36, 72}, {0, 4, 10}};
  hs.want(wish, field, 0.0);
  auto queued = src.openRequests();
  ASSERT_EQ(queued.size(), 3u); // the window
  EXPECT_EQ(queued[0].address.key, wish[0]);
  EXPECT_GT(queued[0].priority, queued[1].priority); // most important first
  EXPECT_GT(queued[1].priority, queued[2].priority);
  // One tile arrives, one is absent, one fails.
  ASSERT_TRUE(src.answer(wish[0], bil16(TileStatus::Ok, 4 * 4 * 2)));
  ASSERT_TRUE(src.answer(wish[1], bil16(TileStatus::Absent)));
  ASSERT_TRUE(src.answer(wish[2], bil16(TileStatus::Failed)));
  hs.want(wish, field, 1.0);
  EXPECT_EQ(hs.stats().received, 1u);
  EXPECT_EQ(hs.stats().absent, 1u);
  EXPECT_EQ(hs.stats().failed, 1u);
  // The window refills with what is left: not the absent one, not the failed one before its retry.
  queued = src.openRequests();
  ASSERT_EQ(queued.size(), 2u);
  EXPECT_EQ(queued[0].address.key, wish[3]);
  EXPECT_EQ(queued[1].address.key, wish[4]);
  EXPECT_TRUE(hs.settled(wish[1], field));
  EXPECT_TRUE(hs.settled(wish[2], field)); // failed: settled until its retry
  // Delivery into the field, at most as many as asked.
  EXPECT_FALSE(field.contains(wish[0]));
  EXPECT_EQ(hs.deliver(field, 0), 0u);
  EXPECT_EQ(hs.deliver(field, 5), 1u);
  EXPECT_TRUE(field.contains(wish[0]));
  // No longer wished: queued requests are cancelled.
  hs.want(std::vector<TileKey>{wish[3]}, field, 2.0);
  EXPECT_EQ(src.cancelled().size(), 1u);
  ASSERT_EQ(src.openCount(), 1u);
  // After retryAfterS the failed tile is asked again; the absent one never.
  ASSERT_TRUE(src.answer(wish[3], bil16(TileStatus::Ok, 4 * 4 * 2)));
  hs.want(wish, field, 7.0);
  bool retried = false, absentAgain = false;
  for (const auto& r : src.openRequests()) {
    retried = retried || r.address.key == wish[2];
    absentAgain = absentAgain || r.address.key == wish[1];
  }
  EXPECT_TRUE(retried);
  EXPECT_FALSE(absentAgain);
}

TEST(HeightStreamer, UndecodableBytesAreCountedAndNotAskedAgain) {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 20.0;
  spec.tileWidth = spec.tileHeight = 4;
  spec.numLevels = 2;
  const TileGrid grid = *TileGrid::create(spec);
  FakeTileSource src;
  heldHeights(src, spec);
  HeightStreamer hs(src, grid, HeightStreamParams{"h", "", 4, {}, 5.0});
  HeightField field(grid);
  const std::vector<TileKey> wish{{0, 1, 1}};
  hs.want(wish, field, 0.0);
  ASSERT_TRUE(src.answer(wish[0], bil16(TileStatus::Ok, 7))); // not 4 x 4 x 2 bytes
  hs.want(wish, field, 10.0);
  EXPECT_EQ(hs.stats().decodeErrors, 1u);
  EXPECT_EQ(src.openCount(), 0u);
  EXPECT_TRUE(hs.settled(wish[0], field));
  EXPECT_FALSE(hs.busy());
}

// --- The geoid applied to terrain heights (issue #8): h = H + N, once per tile. ---

std::shared_ptr<const Geoid> bundledGeoid() {
  auto g = Geoid::open(std::filesystem::path(TELLUS_TEST_DATA_DIR) / kGeoidFileName);
  if (!g) throw std::runtime_error(g.error());
  return std::make_shared<const Geoid>(std::move(*g));
}

TEST(GeoidTerrain, EachSampleGetsGeographicLibsUndulationAtItsCentre) {
  const auto geoid = bundledGeoid();
  const VerticalDatum datum(geoid);
  const TileGrid grid = elevationGrid(150, 6);
  // Level 0 over New Guinea (N up to +85 m) and a tile south of India (N down to -107 m).
  for (const TileKey k : {TileKey{0, 4, 16}, TileKey{0, 4, 12}}) {
    HeightTile t = tileOf(grid, k, [](double lat, double lon) { return 100.0 + lat - lon; });
    const HeightTile msl = t;
    const Sector s = grid.sectorOf(k);
    applyVerticalDatum(t, s, datum);
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (int y = 0; y < t.height; ++y)
      for (int x = 0; x < t.width; ++x) {
        const double lat = s.north - (y + 0.5) * (s.north - s.south) / t.height;
        const double lon = s.west + (x + 0.5) * (s.east - s.west) / t.width;
        const std::size_t i = static_cast<std::size_t>(y * t.width + x);
        // H + N with N from GeographicLib's Geoid (behind tellus::Geoid), to the float's
        // resolution (N is evaluated along the row, Geoid::undulationsAlongParallel).
        ASSERT_NEAR(
            t.metres[i], static_cast<double>(msl.metres[i]) + geoid->undulationM(lat, lon), 1e-4)
            << lat << ", " << lon;
        lo = std::min(lo, t.metres[i]);
        hi = std::max(hi, t.metres[i]);
      }
    EXPECT_EQ(t.minM, lo);
    EXPECT_EQ(t.maxM, hi);
  }
  // Off: nothing changes, bit for bit.
  HeightTile t = tileOf(grid, {0, 4, 16}, [](double lat, double) { return lat; });
  const HeightTile before = t;
  applyVerticalDatum(t, grid.sectorOf(t.key), VerticalDatum{});
  EXPECT_EQ(t.metres, before.metres);
  EXPECT_EQ(t.minM, before.minM);
  EXPECT_EQ(t.maxM, before.maxM);
}

TEST(GeoidTerrain, SeaLevelOnTheEllipsoidMatchesEgm96AtNgasTestPoints) {
  // NGA's EGM96 test values (the README of the WW15MGH grid: spherical harmonics to degree 360),
  // read through the height field as the renderer reads terrain: a sea-level tile (H = 0) of a
  // level whose samples are 0.008 degrees apart, moved onto the ellipsoid. The bundled 30' grid's
  // bilinear interpolation is within 0.15 m RMS of EGM96 (3.9 m at worst, in the Andes): these
  // open-ocean and plain points are within 0.25 m; against GeographicLib's value at the same
  // point (tellus::Geoid) the field is within 1 cm (N interpolated between sample centres).
  struct Point {
    double lat, lon, n;
  };
  constexpr Point kNga[] = {
      {38.6281550, 269.7791550, -31.628},
      {-14.6212170, 305.0211140, -2.969},
      {46.8743190, 102.4487290, -43.575},
      {-23.6174460, 133.8747120, 15.871},
      {38.6254730, 359.9995000, 50.066},
      {-0.4667440, 0.0023000, 17.329},
  };
  const auto geoid = bundledGeoid();
  const TileGrid grid = elevationGrid(150, 6);
  for (const Point& p : kNga) {
    const double lon = std::remainder(p.lon, 360.0);
    HeightField field(grid);
    const TileKey centre = *grid.keyAt(p.lat, lon, 4);
    for (std::int64_t dr = -1; dr <= 1; ++dr)
      for (std::int64_t dc = -1; dc <= 1; ++dc) {
        const TileKey k{4, centre.row + dr, centre.col + dc};
        HeightTile t = tileOf(grid, k, [](double, double) { return 0.0; });
        applyVerticalDatum(t, grid.sectorOf(k), VerticalDatum(geoid));
        ASSERT_TRUE(field.insert(std::move(t)));
      }
    const double h = field.heightAt(p.lat, lon);
    EXPECT_NEAR(h, geoid->undulationM(p.lat, lon), 0.01) << p.lat << ", " << lon;
    EXPECT_NEAR(h, p.n, 0.25) << p.lat << ", " << lon;
  }
}

TEST(GeoidTerrain, TheStreamerMovesTilesOntoTheEllipsoidOnTheWorkerThread) {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 20.0;
  spec.tileWidth = spec.tileHeight = 4;
  spec.numLevels = 2;
  const TileGrid grid = *TileGrid::create(spec);
  const auto geoid = bundledGeoid();
  for (const bool on : {false, true}) {
    FakeTileSource src;
    heldHeights(src, spec);
    HeightStreamParams p{"h", "", 4, {}, 5.0};
    if (on) p.datum = VerticalDatum(geoid);
    HeightStreamer hs(src, grid, p);
    HeightField field(grid);
    const TileKey key{0, 4, 16}; // New Guinea, N about +60 to +85 m
    hs.want(std::vector<TileKey>{key}, field, 0.0);
    ASSERT_TRUE(src.answer(key, bil16(TileStatus::Ok, 4 * 4 * 2))); // all zeros: sea level
    hs.want(std::vector<TileKey>{key}, field, 1.0);
    ASSERT_EQ(hs.deliver(field, 4), 1u);
    const Sector s = grid.sectorOf(key);
    const double lat = s.north - 2.5 * (s.north - s.south) / 4, lon = s.west + 1.5 * 5.0;
    EXPECT_NEAR(field.heightAt(lat, lon), on ? geoid->undulationM(lat, lon) : 0.0, 1e-5);
    if (on) {
      EXPECT_GT(field.heightAt(lat, lon), 40.0);
    }
  }
}

TEST(TerrainMesh, NonFiniteHeightsNeverReachAVertex) {
  // A height function that answers NaN, +inf or -inf in places (the height field never does for
  // finite input; a broken decoder or a division by zero in a caller's function could): those
  // points sit on the ellipsoid, and no position, normal, texture coordinate or height range of
  // the mesh is NaN or inf (debug builds assert the same inside buildTerrainMesh and
  // buildPatchMesh). Also at a pole row and with a side fixed onto a coarser neighbour.
  const Geodesy wgs;
  const double inf = std::numeric_limits<double>::infinity();
  const HeightFunction broken = [inf](double lat, double lon) {
    const int k = static_cast<int>(std::floor(lat * 7.0 + lon * 3.0)) % 4;
    return k == 0 ? std::nan("") : k == 1 ? inf : k == 2 ? -inf : 1000.0;
  };
  std::array<EdgeAdapt, 4> fixedNorth{};
  fixedNorth[0] = {true, {0.0, 18.0, 36.0, 36.0}, {}};
  struct Case {
    Sector sector;
    std::array<EdgeAdapt, 4> edges;
  };
  for (const Case& c : {Case{{0.0, 0.0, 18.0, 18.0}, {}},
                        Case{{0.0, 0.0, 18.0, 18.0}, fixedNorth},
                        Case{{-180.0, 72.0, -144.0, 90.0}, {}}}) {
    const TerrainMesh m = buildTerrainMesh(wgs, c.sector, 17, broken, c.edges);
    ASSERT_FALSE(m.vertices.empty());
    for (const TerrainVertex& v : m.vertices) {
      ASSERT_TRUE(std::isfinite(v.position.x) && std::isfinite(v.position.y) &&
                  std::isfinite(v.position.z));
      ASSERT_TRUE(std::isfinite(v.normal.x) && std::isfinite(v.normal.y) &&
                  std::isfinite(v.normal.z));
      ASSERT_NEAR(glm::length(glm::dvec3(v.normal)), 1.0, 1e-3);
      ASSERT_TRUE(v.uvNode.x >= 0.0 && v.uvNode.x <= 1.0 && v.uvNode.y >= 0.0 && v.uvNode.y <= 1.0);
    }
    EXPECT_TRUE(std::isfinite(m.minHeightM));
    EXPECT_TRUE(std::isfinite(m.maxHeightM));
    EXPECT_EQ(m.minHeightM, 0.0); // the non-finite points: on the ellipsoid
    EXPECT_EQ(m.maxHeightM, 1000.0);
    // A grid vertex whose height was not finite lies on the ellipsoid.
    const int n = m.n;
    for (int r = 0; r < n; ++r)
      for (int col = 0; col < n; ++col) {
        const double lat = edgeLerp(c.sector.south, c.sector.north, r, n);
        const double lon = edgeLerp(c.sector.west, c.sector.east, col, n);
        if (c.edges[0].active && r == n - 1) continue; // moved onto the neighbour's chords
        if (std::isfinite(broken(lat, lat == 90.0 ? 0.0 : lon))) continue;
        const Ecef e = wgs.toEcef(lat, lat == 90.0 ? 0.0 : lon, 0.0);
        const glm::dvec3 p = m.vertices[static_cast<std::size_t>(r * n + col)].position;
        EXPECT_NEAR(glm::length(p - glm::dvec3(e.x, e.y, e.z)), 0.0, 1e-6) << lat << ", " << lon;
      }
  }
}

// A polar cap's rim is a whole parallel with its own vertex count, 10 or 20 times a ring node's
// edge (not a power of two): the ring node's vertices go onto the cap's chords by their longitude
// and zero-area fans close the T-junctions, as for quadtree neighbours.
TEST(EdgeFixingExtremes, ARingNodeLiesOnAPolarCapsRim) {
  const int nCap = 17, n = 9;
  const Sector cap{-180.0, 81.0, 180.0, 90.0};
  const auto capMesh = buildTerrainMesh(wgs84(), cap, nCap, bumpy, {});
  std::vector<glm::dvec3> rim; // its south side (row 0), west to east
  for (int c = 0; c < nCap; ++c)
    rim.push_back(capMesh.vertices[static_cast<std::size_t>(c)].position);
  for (const Sector fine : {Sector{18.0, 72.0, 36.0, 81.0},
                            Sector{-180.0, 72.0, -144.0, 81.0},
                            Sector{144.0, 76.5, 180.0, 81.0}}) {
    std::array<EdgeAdapt, 4> edges{};
    edges[static_cast<std::size_t>(Direction::North)] = {true, cap, rim};
    const auto fixed = buildTerrainMesh(wgs84(), fine, n, bumpy, edges);
    const auto plain = buildTerrainMesh(wgs84(), fine, n, bumpy, {});
    double before = 0.0;
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>((n - 1) * n + i);
      EXPECT_LT(toPolyline(fixed.vertices[k].position, rim), 1e-6) << fine.west << " " << i;
      before = std::max(before, toPolyline(plain.vertices[k].position, rim));
    }
    EXPECT_GT(before, 1.0); // 22.5-degree chords: kilometres inside the circle
    // A rim vertex within the edge is drawn at the very same place.
    for (const auto& cv : rim)
      for (int i = 0; i < n; ++i) {
        const auto& p = fixed.vertices[static_cast<std::size_t>((n - 1) * n + i)].position;
        if (glm::length(cv - p) < 1e-6) {
          EXPECT_EQ(cv, p);
        }
      }
    EXPECT_GT(fixed.zeroAreaTriangles, 0u);
    for (std::size_t q = 2; q < 4; ++q) { // the north quadrants hold the fans
      const std::size_t cells =
          static_cast<std::size_t>((n - 1) / 2) * static_cast<std::size_t>((n - 1) / 2) * 6;
      for (std::size_t i = fixed.quadrantStart[q] + cells; i < fixed.quadrantStart[q + 1]; i += 3) {
        const glm::dvec3 a = fixed.vertices[fixed.indices[i]].position;
        const glm::dvec3 b = fixed.vertices[fixed.indices[i + 1]].position;
        const glm::dvec3 c = fixed.vertices[fixed.indices[i + 2]].position;
        EXPECT_LT(glm::length(glm::cross(b - a, c - a)), 1e-3 * glm::length(b - a) + 1e-6);
        EXPECT_LT(toPolyline(a, rim), 1e-6);
        EXPECT_LT(toPolyline(c, rim), 1e-6);
      }
    }
  }
}

// A polar cap's mesh: 129 columns for its rim, the 33 rows every node of its level has (a
// quarter of the vertices a square grid would take). Each row lies on its parallel, all four
// quadrants are cells, and edge fixing, which needs a square grid, is refused.
TEST(TerrainMesh, ACapsMeshHasMoreColumnsThanRows) {
  const Sector cap{-180.0, 81.0, 180.0, 90.0};
  const auto m = buildTerrainMesh(wgs84(), cap, 129, bumpy, {}, 33);
  EXPECT_EQ(m.n, 129);
  EXPECT_EQ(m.rows, 33);
  ASSERT_EQ(m.vertices.size(), 129u * 33u);
  EXPECT_EQ(m.indices.size(), 128u * 32u * 6u);
  for (std::size_t q = 0; q < 4; ++q) // 64 x 16 cells each
    EXPECT_EQ(m.quadrantStart[q + 1] - m.quadrantStart[q], 64u * 16u * 6u) << q;
  for (int r = 0; r < 33; ++r)
    for (const int c : {0, 37, 128}) {
      const TerrainVertex& v = m.vertices[static_cast<std::size_t>(r * 129 + c)];
      const double lat = edgeLerp(81.0, 90.0, r, 33);
      const double lon = lat == 90.0 ? 0.0 : edgeLerp(-180.0, 180.0, c, 129); // the pole: one point
      const Ecef e = wgs84().toEcef(lat, lon, bumpy(lat, lon));
      EXPECT_LT(glm::length(v.position - glm::dvec3(e.x, e.y, e.z)), 1e-6) << r << " " << c;
      EXPECT_DOUBLE_EQ(v.uvNode.y, r / 32.0);
    }
  std::array<EdgeAdapt, 4> edges{};
  edges[static_cast<std::size_t>(Direction::South)] = {true, {-180.0, 72.0, 180.0, 81.0}, {}};
  EXPECT_THROW(buildTerrainMesh(wgs84(), cap, 129, bumpy, edges, 33), std::invalid_argument);
  EXPECT_THROW(buildTerrainMesh(wgs84(), cap, 129, bumpy, {}, 32), std::invalid_argument);
}

// A cap's rim vertex can fall between two of a ring node's (129 rim vertices against a 33-vertex
// node 36 degrees wide: 2.5 of its steps a chord). Then the node's straight segment cuts the rim's
// kink, and only a triangle with area closes the gap (with relief, a height step: the south pole's
// relief view showed background pixels there). The node's open edges along the rim must be the
// rim itself: each on the polyline, and together covering it between the node's corners.
TEST(EdgeFixingExtremes, ARimVertexBetweenTwoOfARingNodesIsClosed) {
  const int nCap = 33, n = 9; // 11.25-degree chords over 4.5-degree steps
  const Sector cap{-180.0, 81.0, 180.0, 90.0};
  const auto capMesh = buildTerrainMesh(wgs84(), cap, nCap, bumpy, {});
  std::vector<glm::dvec3> rim;
  for (int c = 0; c < nCap; ++c)
    rim.push_back(capMesh.vertices[static_cast<std::size_t>(c)].position);
  for (const Sector fine : {Sector{144.0, 72.0, 180.0, 81.0}, Sector{-180.0, 72.0, -144.0, 81.0}}) {
    std::array<EdgeAdapt, 4> edges{};
    edges[static_cast<std::size_t>(Direction::North)] = {true, cap, rim};
    const auto m = buildTerrainMesh(wgs84(), fine, n, bumpy, edges);
    EXPECT_EQ(m.kinkTriangles, 2u); // rim vertices at 146.25 and 168.75 (-168.75 and -146.25)
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
    for (std::size_t i = 0; i < m.indices.size(); i += 3)
      for (int e = 0; e < 3; ++e) {
        std::uint32_t a = m.indices[i + static_cast<std::size_t>(e)],
                      b = m.indices[i + static_cast<std::size_t>((e + 1) % 3)];
        if (a > b) std::swap(a, b);
        ++uses[{a, b}];
      }
    std::vector<std::pair<glm::dvec3, glm::dvec3>> open;
    for (const auto& [edge, count] : uses) {
      if (count != 1) continue;
      const glm::dvec3 a = m.vertices[edge.first].position, b = m.vertices[edge.second].position;
      if (toPolyline(a, rim) > 1e-6 || toPolyline(b, rim) > 1e-6) continue; // another side
      EXPECT_LT(toPolyline(0.5 * (a + b), rim), 1e-6) << fine.west << ": an edge cuts a kink";
      open.emplace_back(a, b);
    }
    // And they cover the rim between the node's corners.
    for (int k = 0; k <= 360; ++k) {
      const double lon = fine.west + (fine.east - fine.west) * k / 360.0;
      const double x = (lon + 180.0) / 11.25;
      const auto j = std::min<std::size_t>(static_cast<std::size_t>(x), rim.size() - 2);
      const glm::dvec3 p = rim[j] + (rim[j + 1] - rim[j]) * (x - static_cast<double>(j));
      bool covered = false;
      for (const auto& [a, b] : open)
        covered = covered || toPolyline(p, {a, b}) < 1e-6;
      EXPECT_TRUE(covered) << fine.west << " at " << lon;
    }
  }
}

} // namespace
} // namespace tellus::planet
