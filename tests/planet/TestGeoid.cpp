// The EGM96 geoid (data/egm96-30.pgm) through tellus::Geoid, and the MSL -> ellipsoid switch.
// Expected values are EGM96's own: nodes of PROJ's egm96_15.gtx (read when the grid was made, see
// data/README.md), which the 30' grid keeps to its 3 mm quantisation step.

#include "../support/TempDir.hpp"

#include <tellus/planet/Geoid.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <thread>
#include <vector>

using namespace tellus;

namespace {

const std::filesystem::path kGrid = std::filesystem::path(TELLUS_TEST_DATA_DIR) / kGeoidFileName;

Geoid openGrid(Geoid::Interpolation i = Geoid::Interpolation::Bilinear) {
  auto g = Geoid::open(kGrid, i);
  if (!g) throw std::runtime_error(g.error());
  return std::move(*g);
}

struct Node {
  double lat, lon, n; // egm96_15.gtx at a node the 30' grid keeps
};
constexpr Node kNodes[] = {
    {0.0, 0.0, 17.161579},
    {90.0, 0.0, 13.606245},
    {-90.0, 0.0, -29.533850},
    {0.0, 180.0, 21.153330},
    {45.0, 179.5, -6.672834},
    {-30.5, -179.5, 46.137234},
    {27.5, 86.5, -39.129246},
    {51.5, -0.5, 46.403801},
    {-4.5, 147.5, 78.590485},
    {-8.5, 147.5, 84.625221},
    {4.5, 79.0, -106.974716},
    {38.5, -77.0, -33.956772},
};

} // namespace

TEST(Geoid, BilinearGivesEgm96AtTheGridNodes) {
  const Geoid g = openGrid();
  EXPECT_EQ(g.interpolation(), Geoid::Interpolation::Bilinear);
  EXPECT_NE(g.description().find("EGM96"), std::string::npos) << g.description();
  for (const Node& p : kNodes)
    EXPECT_NEAR(g.undulationM(p.lat, p.lon), p.n, 0.0016) << p.lat << ", " << p.lon;
}

// Between the 30' nodes: the 15' nodes the conversion dropped. The worst of them (Colombia, where
// the geoid bends sharply) is 3.9 m off bilinearly, the RMS 0.15 m (tools/geoid_gtx_to_pgm.py);
// the highest 15' node (New Guinea) is 1.9 m off, the lowest (south of India) 0.1 m.
TEST(Geoid, BetweenNodesStaysWithinTheConversionsStatedError) {
  for (auto interp : {Geoid::Interpolation::Bilinear, Geoid::Interpolation::Cubic}) {
    const Geoid g = openGrid(interp);
    EXPECT_NEAR(g.undulationM(10.75, -73.75), 5.657658, 4.0);
    EXPECT_NEAR(g.undulationM(-8.25, 147.25), 85.390923, 2.0);
    EXPECT_NEAR(g.undulationM(4.75, 78.75), -106.991089, 1.0);
    if (interp == Geoid::Interpolation::Cubic) {
      for (const Node& p : kNodes) { // a least-squares fit: near, not at, the nodes
        EXPECT_NEAR(g.undulationM(p.lat, p.lon), p.n, 0.5) << p.lat << ", " << p.lon;
      }
    }
  }
  EXPECT_NEAR(openGrid().statedMaxErrorM(), 3.925, 1e-9); // the file's MaxBilinearError
}

// Bilinear is continuous across the grid's cell edges (steps of a 1e-7 degree move stay below
// 0.1 mm); GeographicLib's cubic fit is made cell by cell and is not: it steps at cell edges
// (printed: up to 1.06 m on these lines, 8.5 cm at 45.2 N, 10 E). That is why Bilinear is the
// default: terrain heights moved by the geoid must not step at every 30' line.
TEST(Geoid, BilinearIsContinuousAcrossCellEdgesCubicIsNot) {
  const Geoid bilinear = openGrid();
  const Geoid cubic = openGrid(Geoid::Interpolation::Cubic);
  const double eps = 1e-7;
  double worstBilinear = 0.0, worstCubic = 0.0;
  for (double lat = -89.75; lat < 90.0; lat += 1.37)
    for (double lon = -180.0; lon <= 180.0; lon += 0.5) { // every meridian cell edge on the line
      worstBilinear = std::max(
          worstBilinear,
          std::abs(bilinear.undulationM(lat, lon - eps) - bilinear.undulationM(lat, lon + eps)));
      worstCubic =
          std::max(worstCubic,
                   std::abs(cubic.undulationM(lat, lon - eps) - cubic.undulationM(lat, lon + eps)));
    }
  for (double lon = -179.9; lon < 180.0; lon += 1.37)
    for (double lat = -89.5; lat <= 89.5; lat += 0.5) { // every parallel cell edge
      worstBilinear = std::max(
          worstBilinear,
          std::abs(bilinear.undulationM(lat - eps, lon) - bilinear.undulationM(lat + eps, lon)));
      worstCubic =
          std::max(worstCubic,
                   std::abs(cubic.undulationM(lat - eps, lon) - cubic.undulationM(lat + eps, lon)));
    }
  std::printf("largest step across a cell edge: bilinear %.6f m, cubic %.3f m\n",
              worstBilinear,
              worstCubic);
  EXPECT_LT(worstBilinear, 1e-4);
  EXPECT_GT(worstCubic, 0.01);
}

// EGM96's extremes: about +85 m over New Guinea and -107 m south of India (Sri Lanka).
TEST(Geoid, ExtremesAreNewGuineaAndSouthOfIndia) {
  const Geoid g = openGrid();
  double hi = -1e9, lo = 1e9, hiLat = 0, hiLon = 0, loLat = 0, loLon = 0;
  for (double lat = -90.0; lat <= 90.0; lat += 0.25)
    for (double lon = -180.0; lon < 180.0; lon += 0.25) {
      const double n = g.undulationM(lat, lon);
      ASSERT_TRUE(std::isfinite(n)) << lat << ", " << lon;
      if (n > hi) hi = n, hiLat = lat, hiLon = lon;
      if (n < lo) lo = n, loLat = lat, loLon = lon;
    }
  std::printf(
      "max %.3f m at %.2f, %.2f; min %.3f m at %.2f, %.2f\n", hi, hiLat, hiLon, lo, loLat, loLon);
  EXPECT_NEAR(hi, 85.0, 1.0);
  EXPECT_TRUE(hiLat > -10 && hiLat < 0 && hiLon > 140 && hiLon < 155) << hiLat << ", " << hiLon;
  EXPECT_NEAR(lo, -107.0, 1.0);
  EXPECT_TRUE(loLat > 0 && loLat < 10 && loLon > 75 && loLon < 85) << loLat << ", " << loLon;
}

TEST(Geoid, MslPlusUndulationIsTheEllipsoidHeight) {
  const Geoid g = openGrid();
  const double n = g.undulationM(0.0, 0.0);
  EXPECT_DOUBLE_EQ(g.ellipsoidHeightM(0.0, 0.0, 100.0), 100.0 + n);
  EXPECT_DOUBLE_EQ(g.mslHeightM(0.0, 0.0, 100.0 + n), 100.0);
  EXPECT_DOUBLE_EQ(g.mslHeightM(4.5, 79.0, g.ellipsoidHeightM(4.5, 79.0, -5.0)), -5.0);
}

TEST(Geoid, VerticalDatumSwitchesTheGeoidOnAndOff) {
  const VerticalDatum off;
  EXPECT_FALSE(off.usesGeoid());
  EXPECT_EQ(off.ellipsoidHeightM(-8.5, 147.5, 1000.0), 1000.0);
  EXPECT_TRUE(std::isnan(off.ellipsoidHeightM(std::nan(""), 0.0, 1000.0)));
  const VerticalDatum on(std::make_shared<const Geoid>(openGrid()));
  EXPECT_TRUE(on.usesGeoid());
  EXPECT_NEAR(on.ellipsoidHeightM(-8.5, 147.5, 1000.0), 1084.625, 0.002);
  EXPECT_NEAR(on.ellipsoidHeightM(4.5, 79.0, 0.0), -106.975, 0.002);
  const VerticalDatum copy = on; // shares the grid
  EXPECT_EQ(copy.ellipsoidHeightM(10.0, 20.0, 0.0), on.ellipsoidHeightM(10.0, 20.0, 0.0));
}

TEST(Geoid, AlongAParallelAgreesWithPointByPoint) {
  // What applyVerticalDatum uses per row of a height tile: lookups at the grid's meridians only,
  // linear between them (bilinear is linear in longitude inside a cell). Rows inside one cell,
  // across many cells, across the antimeridian, at the poles, with negative steps; cubic falls
  // back to one lookup per sample.
  for (const auto interpolation : {Geoid::Interpolation::Bilinear, Geoid::Interpolation::Cubic}) {
    const Geoid g = openGrid(interpolation);
    struct Row {
      double lat, lon0, dLon;
      int count;
    };
    for (const Row r : {Row{45.9, 7.51, 0.001, 150},
                        Row{-8.5, 140.0 + 20.0 / 300.0, 20.0 / 150.0, 150},
                        Row{10.0, 179.0, 0.01, 300},
                        Row{-33.3, -179.99, 0.37, 40},
                        Row{90.0, -180.0, 1.0, 360},
                        Row{-90.0, 0.5, 2.5, 100},
                        Row{4.5, 80.0, -0.05, 200},
                        Row{0.0, 0.0, 0.5, 10}}) {
      std::vector<double> out(static_cast<std::size_t>(r.count));
      g.undulationsAlongParallel(r.lat, r.lon0, r.dLon, out);
      for (int i = 0; i < r.count; ++i) {
        const double lon = r.lon0 + i * r.dLon;
        ASSERT_NEAR(out[static_cast<std::size_t>(i)], g.undulationM(r.lat, lon), 1e-9)
            << r.lat << ", " << lon;
      }
    }
    std::vector<double> bad(3);
    g.undulationsAlongParallel(std::nan(""), 0.0, 1.0, bad);
    EXPECT_TRUE(std::isnan(bad[0]) && std::isnan(bad[2]));
    g.undulationsAlongParallel(91.0, 0.0, 1.0, bad);
    EXPECT_TRUE(std::isnan(bad[1]));
  }
}

TEST(Geoid, MissingOrBrokenFilesAreRefusedWithTheirName) {
  const auto missing = Geoid::open("/nonexistent/egm96-30.pgm");
  ASSERT_FALSE(missing.has_value());
  EXPECT_NE(missing.error().find("/nonexistent/egm96-30.pgm"), std::string::npos);
  EXPECT_FALSE(Geoid::open(std::filesystem::path(TELLUS_TEST_DATA_DIR) / "README.md"));
  test::TempDir dir("geoid");
  const auto broken = dir.path() / "broken.pgm";
  {
    std::ofstream f(broken, std::ios::binary);
    f << "P5\n# Offset -108\n# Scale 0.003\n720 361\n65535\n" << std::string(1000, 'x');
  }
  const auto b = Geoid::open(broken);
  ASSERT_FALSE(b.has_value());
  EXPECT_NE(b.error().find("broken.pgm"), std::string::npos) << b.error();
}

// The grid is read whole at open(): concurrent calls need no lock and agree with one thread's
// (run under TSan by make test-sanitizers).
TEST(Geoid, ConcurrentCallsAgreeWithOneThread) {
  for (auto interp : {Geoid::Interpolation::Bilinear, Geoid::Interpolation::Cubic}) {
    const Geoid g = openGrid(interp);
    std::vector<double> expected;
    for (int i = 0; i < 2000; ++i)
      expected.push_back(g.undulationM(-89.0 + i * 0.089, -180.0 + i * 0.179));
    std::vector<std::thread> threads;
    std::vector<int> mismatches(4, 0);
    for (std::size_t t = 0; t < 4; ++t)
      threads.emplace_back([&, t] {
        for (int i = 0; i < 2000; ++i)
          mismatches[t] += g.undulationM(-89.0 + i * 0.089, -180.0 + i * 0.179) !=
                           expected[static_cast<std::size_t>(i)];
      });
    for (auto& th : threads)
      th.join();
    for (int m : mismatches)
      EXPECT_EQ(m, 0);
  }
}

// Poles, the antimeridian, -0.0 and non-finite input.
TEST(GeoidExtremes, PolesAntimeridianNegativeZeroAndNonFiniteInput) {
  for (auto interp : {Geoid::Interpolation::Bilinear, Geoid::Interpolation::Cubic}) {
    const Geoid g = openGrid(interp);
    // One value at each pole whatever the longitude, and close to it just off the pole.
    const double north = g.undulationM(90.0, 0.0), south = g.undulationM(-90.0, 0.0);
    EXPECT_NEAR(north, 13.606, 0.01);
    EXPECT_NEAR(south, -29.534, 0.01);
    for (double lon : {-180.0, -179.5, -45.0, 0.25, 77.7, 179.99, 180.0, 1e6}) {
      EXPECT_NEAR(g.undulationM(90.0, lon), north, 1e-9) << lon;
      EXPECT_NEAR(g.undulationM(-90.0, lon), south, 1e-9) << lon;
      EXPECT_NEAR(g.undulationM(89.9999, lon), north, 0.02) << lon;
      EXPECT_NEAR(g.undulationM(-89.9999, lon), south, 0.02) << lon;
    }
    // The antimeridian: 180, -180 and every wrap agree; the two sides meet.
    for (double lat : {-89.9, -45.3, 0.0, 12.34, 66.6, 89.9}) {
      const double at = g.undulationM(lat, 180.0);
      EXPECT_EQ(g.undulationM(lat, -180.0), at) << lat;
      EXPECT_NEAR(g.undulationM(lat, 540.0), at, 1e-9) << lat;
      EXPECT_NEAR(g.undulationM(lat, -900.0), at, 1e-9) << lat;
      if (interp == Geoid::Interpolation::Bilinear) { // cubic steps at cell edges (above)
        EXPECT_NEAR(g.undulationM(lat, 179.9999), at, 0.001) << lat;
        EXPECT_NEAR(g.undulationM(lat, -179.9999), at, 0.001) << lat;
      }
      EXPECT_TRUE(std::isfinite(g.undulationM(lat, 1e300))) << lat;
      EXPECT_TRUE(std::isfinite(g.undulationM(lat, -1e300))) << lat;
    }
    // -0.0 is 0.
    EXPECT_EQ(g.undulationM(-0.0, -0.0), g.undulationM(0.0, 0.0));
    EXPECT_EQ(g.undulationM(-0.0, 10.0), g.undulationM(0.0, 10.0));
    EXPECT_EQ(g.undulationM(10.0, -0.0), g.undulationM(10.0, 0.0));
    // NaN, inf and latitudes past the poles: NaN, no crash.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    for (auto [lat, lon] : {std::pair{nan, 0.0},
                            {0.0, nan},
                            {nan, nan},
                            {inf, 0.0},
                            {-inf, 0.0},
                            {0.0, inf},
                            {0.0, -inf},
                            {90.000001, 0.0},
                            {-90.000001, 0.0},
                            {1e300, 0.0},
                            {std::numeric_limits<double>::denorm_min(), inf}}) {
      EXPECT_TRUE(std::isnan(g.undulationM(lat, lon))) << lat << ", " << lon;
      EXPECT_TRUE(std::isnan(g.ellipsoidHeightM(lat, lon, 0.0))) << lat << ", " << lon;
    }
    EXPECT_TRUE(std::isnan(g.ellipsoidHeightM(0.0, 0.0, nan)));
    EXPECT_TRUE(std::isfinite(g.undulationM(std::numeric_limits<double>::denorm_min(), 0.0)));
    EXPECT_TRUE(std::isfinite(g.undulationM(-90.0 + 1e-14, 0.0)));
  }
}
