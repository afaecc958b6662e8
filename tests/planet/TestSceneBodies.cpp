// Several bodies in one scene (issue 26; planet/SceneBodies.hpp), GL-free: the Earth-Moon
// distance and directions the placement gives, its rotations, the Moon's near side facing the
// Earth, and the distant globe's camera-relative vertices (the eye subtracted in double).

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/Moon.hpp>
#include <tellus/planet/SceneBodies.hpp>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus::planet;
using astro::EphemerisBody;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
// 1992 April 12, 0h TD (Meeus's example 47.a), as UTC (TT - UTC taken as 69.184 s).
constexpr double kMeeus47a = 703036800.0 - 69.184;
constexpr double kFirstQuarter2024 = 1705549920.0; // 2024-01-18 03:52 UTC

double maxAbsDiff(const glm::dmat3& a, const glm::dmat3& b) {
  double m = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      m = std::max(m, std::abs(a[c][r] - b[c][r]));
  return m;
}

} // namespace

TEST(SceneBodies, OnlyBodiesWithAnEphemerisShareAScene) {
  EXPECT_EQ(sceneBodyOf(earthBody()), EphemerisBody::earth);
  EXPECT_EQ(sceneBodyOf(earthSphereBody()), EphemerisBody::earth);
  EXPECT_EQ(sceneBodyOf(moonBody()), EphemerisBody::moon);
  EXPECT_EQ(sceneBodyOf(marsBody()), EphemerisBody::mars);
  Body vesta = moonBody();
  vesta.name = "vesta";
  EXPECT_FALSE(sceneBodyOf(vesta));
}

TEST(SceneBodies, TheMoonFromTheEarthIsAtMeeussDistance) {
  const BodyPlacement moon = placeBody(EphemerisBody::earth, EphemerisBody::moon, kMeeus47a);
  // Meeus 47.a: Delta = 368,409.7 km (the centres' distance), to its printed digit.
  EXPECT_NEAR(glm::length(moon.centre) / 1000.0, 368409.7, 0.1);
  // The direction is the celestial one turned into ECEF at that instant.
  const glm::dvec3 celestial = astro::bodyPositionCelestial(EphemerisBody::moon, kMeeus47a);
  const glm::dvec3 ecef = astro::celestialToEcef(kMeeus47a) * celestial;
  EXPECT_LT(glm::length(moon.centre - ecef), 1e-6);
}

TEST(SceneBodies, EachBodySeesTheOtherOppositeAndTheRotationsInvert) {
  for (const double t : {kMeeus47a, kFirstQuarter2024, 1.9e9}) {
    const BodyPlacement moon = placeBody(EphemerisBody::earth, EphemerisBody::moon, t);
    const BodyPlacement earth = placeBody(EphemerisBody::moon, EphemerisBody::earth, t);
    EXPECT_NEAR(glm::length(moon.centre), glm::length(earth.centre), 1e-6);
    // The Earth from the Moon, turned into the Earth's frame, is minus the Moon from the Earth.
    EXPECT_LT(glm::length(moon.rotation * earth.centre + moon.centre), 1e-4);
    EXPECT_LT(maxAbsDiff(moon.rotation * earth.rotation, glm::dmat3(1.0)), 1e-14);
    EXPECT_NEAR(glm::determinant(moon.rotation), 1.0, 1e-14);
    const double d = glm::length(moon.centre) / 1000.0;
    EXPECT_GT(d, 356000.0);
    EXPECT_LT(d, 407000.0);
    const BodyPlacement self = placeBody(EphemerisBody::moon, EphemerisBody::moon, t);
    EXPECT_EQ(self.centre, glm::dvec3(0.0));
  }
}

TEST(SceneBodies, TheMoonsNearSideFacesTheEarth) {
  // The Earth seen from the Moon's centre stands over the mean sub-Earth point (0, 0) to within
  // the librations (7.9 degrees in longitude, 6.9 in latitude), every day of a month.
  for (int day = 0; day < 30; ++day) {
    const double t = kFirstQuarter2024 + day * 86400.0;
    const glm::dvec3 e =
        glm::normalize(placeBody(EphemerisBody::moon, EphemerisBody::earth, t).centre);
    EXPECT_LT(std::abs(std::asin(e.z) / kDeg), 7.0) << day;
    EXPECT_LT(std::abs(std::atan2(e.y, e.x) / kDeg), 8.2) << day;
  }
}

TEST(SceneBodies, AtFirstQuarterTheSunIsSquareToTheMoon) {
  // Sun-Earth-Moon near 90 degrees (2024-01-18 03:52 UTC): the Moon half lit from the Earth.
  const glm::dvec3 moon = glm::normalize(
      placeBody(EphemerisBody::earth, EphemerisBody::moon, kFirstQuarter2024).centre);
  const glm::dvec3 sun = astro::sunDirectionEcef(kFirstQuarter2024);
  EXPECT_NEAR(std::acos(glm::dot(moon, sun)) / kDeg, 90.0, 1.0);
}

TEST(SceneBodies, TheDistantGlobeIsTheBodysEllipsoid) {
  const DistantGlobe g(earthBody(), 16, 8);
  ASSERT_EQ(g.vertexCount(), 17u * 9u);
  // Two triangles a quad, one in each polar row.
  EXPECT_EQ(g.indices().size(), static_cast<std::size_t>(16 * (2 * 8 - 2) * 3));
  for (std::size_t i = 0; i < g.vertexCount(); ++i) {
    const glm::dvec3 p = g.fixedPosition(i);
    const double e = (p.x * p.x + p.y * p.y) / (6378137.0 * 6378137.0) +
                     p.z * p.z / (6356752.314245 * 6356752.314245);
    EXPECT_NEAR(e, 1.0, 1e-9);
    EXPECT_NEAR(glm::length(g.fixedNormal(i)), 1.0, 1e-12);
  }
  EXPECT_FLOAT_EQ(g.uv(0).x, 0.0f);
  EXPECT_FLOAT_EQ(g.uv(g.vertexCount() - 1).y, 1.0f);
  EXPECT_THROW(DistantGlobe(moonBody(), 4, 2), std::invalid_argument);
}

TEST(SceneBodies, VerticesAreCameraRelativeBeforeTheyAreFloats) {
  // The eye exactly at one of the Earth's vertices, 384,000 km from the Moon's frame's origin:
  // that vertex comes out within a micrometre of 0 (a float of the Earth-Moon distance is
  // 32 m coarse), its neighbour at its true 1,000-km-scale offset to float precision.
  const DistantGlobe g(earthBody(), 32, 16);
  const BodyPlacement p = placeBody(EphemerisBody::moon, EphemerisBody::earth, kFirstQuarter2024);
  const std::size_t at = 8 * 33 + 5;
  const glm::dvec3 eye = p.centre + p.rotation * g.fixedPosition(at);
  std::vector<float> out;
  g.cameraRelative(p, eye, out);
  ASSERT_EQ(out.size(), g.vertexCount() * 8);
  EXPECT_LT(std::abs(out[at * 8]) + std::abs(out[at * 8 + 1]) + std::abs(out[at * 8 + 2]), 1e-6);
  const std::size_t next = at + 1;
  const glm::dvec3 want = p.rotation * (g.fixedPosition(next) - g.fixedPosition(at));
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(out[next * 8 + static_cast<std::size_t>(k)], want[k], 1e-6 * glm::length(want));
  // Normals turned into the scene's frame.
  const glm::dvec3 n = p.rotation * g.fixedNormal(next);
  EXPECT_NEAR(out[next * 8 + 3], n.x, 1e-6);
  EXPECT_NEAR(out[next * 8 + 5], n.z, 1e-6);
}

TEST(SceneBodies, OnlyTheVerticesAStrideDrawsAreMadeCameraRelative) {
  // Stride 4 of a 32 x 16 grid: rows and columns 0, 4, 8, ... written as stride 1 writes them;
  // the rest left as they were (-1 here), and every index of indices(4) among those written.
  const DistantGlobe g(moonBody(), 32, 16);
  const BodyPlacement p = placeBody(EphemerisBody::earth, EphemerisBody::moon, kFirstQuarter2024);
  const glm::dvec3 eye{1.0e7, -2.0e6, 3.0e5};
  std::vector<float> all, some(g.vertexCount() * 8, -1.0f);
  g.cameraRelative(p, eye, all);
  g.cameraRelative(p, eye, some, 4);
  ASSERT_EQ(g.rowLength(), 33u);
  std::size_t written = 0;
  for (std::size_t v = 0; v < g.vertexCount(); ++v) {
    const bool drawn = (v / 33) % 4 == 0 && (v % 33) % 4 == 0;
    for (std::size_t k = 0; k < 8; ++k)
      EXPECT_EQ(some[v * 8 + k], drawn ? all[v * 8 + k] : -1.0f) << v << " " << k;
    written += drawn ? 1 : 0;
  }
  EXPECT_EQ(written, 5u * 9u);
  for (const unsigned i : g.indices(4))
    EXPECT_TRUE((i / 33) % 4 == 0 && (i % 33) % 4 == 0) << i;
}

TEST(SceneBodies, ASmallDiscTakesACoarserGridOfTheSameVertices) {
  const DistantGlobe g(moonBody()); // 128 x 64
  EXPECT_EQ(g.indices(1).size(), static_cast<std::size_t>(128 * (2 * 64 - 2) * 3));
  EXPECT_EQ(g.indices(8).size(), static_cast<std::size_t>(16 * (2 * 8 - 2) * 3));
  EXPECT_EQ(g.indices(3).size(), g.indices(1).size()); // no such stride: the finest
  for (const unsigned i : g.indices(8))
    ASSERT_LT(i, g.vertexCount());
  // n slices are within 0.1 px when n >= pi sqrt(5 r): 16 up to r = 5.2 px, 128 past 41 px.
  EXPECT_EQ(g.strideFor(3.0), 8);
  EXPECT_EQ(g.strideFor(12.0), 4);
  EXPECT_EQ(g.strideFor(40.0), 2);
  EXPECT_EQ(g.strideFor(500.0), 1);
  const DistantGlobe small(moonBody(), 16, 8); // stride 2 leaves 8 x 4 quads, 4 would not
  EXPECT_EQ(small.strideFor(0.1), 2);
  EXPECT_EQ(small.indices(4).size(), small.indices(1).size());
}
