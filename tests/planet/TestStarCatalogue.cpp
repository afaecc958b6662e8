// The star catalogue (planet/StarCatalogue.hpp): the bundled data/stars-hip-6.5.txt read and
// checked against SIMBAD's J2000 places of named stars, malformed text refused with the line,
// placement through the Earth's rotation (Polaris by the pole, one turn per sidereal day), the
// brightness mapping and the colours of B-V.
#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace {

using namespace tellus::planet;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kSiderealDayS = 86164.0905; // mean sidereal day, SI seconds
const std::filesystem::path kFile =
    std::filesystem::path(TELLUS_TEST_DATA_DIR) / kStarCatalogueFileName;

const StarCatalogue& bundled() {
  static const StarCatalogue c = [] {
    auto r = StarCatalogue::open(kFile);
    if (!r) throw std::runtime_error(r.error());
    return std::move(*r);
  }();
  return c;
}

double angleDeg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) / kDeg;
}

/** POSIX seconds of a UTC date (proleptic Gregorian, days from civil). */
double unixOf(int y, int m, int d, double hours = 0.0) {
  y -= m <= 2;
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return (era * 146097.0 + doe - 719468.0) * 86400.0 + hours * 3600.0;
}

TEST(StarCatalogue, BundledFileHoldsTheHipparcosStarsToMagnitude65) {
  const StarCatalogue& c = bundled();
  EXPECT_EQ(c.size(), 8874u); // d3-celestial's stars.8.json cut at V = 6.5 (data/README.md)
  double faintest = -10.0;
  for (const Star& s : c.stars())
    faintest = std::max(faintest, s.vmag);
  EXPECT_LE(faintest, 6.5);
  EXPECT_GE(faintest, 6.4);
  EXPECT_EQ(c.stars().front().hip, 32349); // brightest first: Sirius
}

TEST(StarCatalogue, NamedStarsAtTheirSimbadPlaces) {
  // SIMBAD (ICRS, J2000): RA, Dec in degrees, V and B-V. The file keeps 4 decimals of a degree.
  struct Known {
    int hip;
    const char* name;
    double ra, dec, v, bv;
  };
  for (const Known k : {Known{32349, "Sirius", 101.28715, -16.71612, -1.46, 0.00},
                        Known{11767, "Polaris", 37.95454, 89.26411, 1.98, 0.60},
                        Known{27989, "Betelgeuse", 88.79294, 7.40706, 0.42, 1.85},
                        Known{30438, "Canopus", 95.98796, -52.69566, -0.74, 0.15}}) {
    const Star* s = bundled().find(k.hip);
    ASSERT_NE(s, nullptr) << k.name;
    EXPECT_NEAR(s->raRad / kDeg, k.ra, 2e-4) << k.name;
    EXPECT_NEAR(s->decRad / kDeg, k.dec, 2e-4) << k.name;
    // Hipparcos's V differs from SIMBAD's compiled V by up to 0.12 (Canopus) and B-V by up to
    // 0.35 (Betelgeuse, a variable red supergiant): a coarse check that the columns are right.
    EXPECT_NEAR(s->vmag, k.v, 0.15) << k.name;
    ASSERT_TRUE(s->bv.has_value()) << k.name;
    EXPECT_NEAR(*s->bv, k.bv, 0.4) << k.name;
  }
  EXPECT_EQ(bundled().find(1), nullptr);
}

TEST(StarCatalogue, ParsesCommentsBlankLinesAndUnknownColour) {
  const auto c = StarCatalogue::parse("# header\n\n  # indented comment\n"
                                      "1 0.0000 90.0000 5.00 -\r\n"
                                      "2\t359.9999\t-90\t-1.5\t1.2\n",
                                      "text");
  ASSERT_TRUE(c) << c.error();
  ASSERT_EQ(c->size(), 2u);
  EXPECT_FALSE(c->stars()[0].bv.has_value());
  EXPECT_DOUBLE_EQ(c->stars()[0].decRad, std::numbers::pi / 2);
  EXPECT_NEAR(c->stars()[1].raRad, 359.9999 * kDeg, 1e-12);
  EXPECT_DOUBLE_EQ(*c->stars()[1].bv, 1.2);
}

TEST(StarCatalogue, MalformedTextRefusedWithNameLineAndReason) {
  struct Bad {
    const char* text;
    const char* says;
  };
  for (const Bad b : {Bad{"1 10 20 3.0\n", "expected 5 fields"},
                      Bad{"1 10 20 3.0 0.1 7\n", "expected 5 fields"},
                      Bad{"x 10 20 3.0 0.1\n", "Hipparcos number"},
                      Bad{"0 10 20 3.0 0.1\n", "Hipparcos number"},
                      Bad{"1 360 20 3.0 0.1\n", "right ascension"},
                      Bad{"1 -0.1 20 3.0 0.1\n", "right ascension"},
                      Bad{"1 10 90.5 3.0 0.1\n", "declination"},
                      Bad{"1 10 nan 3.0 0.1\n", "declination"},
                      Bad{"1 10 20 3.0x 0.1\n", "V magnitude"},
                      Bad{"1 10 20 inf 0.1\n", "V magnitude"},
                      Bad{"1 10 20 3.0 blue\n", "B-V"}}) {
    const auto c = StarCatalogue::parse(std::string("# ok\n") + b.text, "cat.txt");
    ASSERT_FALSE(c) << b.text;
    EXPECT_NE(c.error().find("cat.txt:2: "), std::string::npos) << c.error();
    EXPECT_NE(c.error().find(b.says), std::string::npos) << c.error();
  }
  const auto empty = StarCatalogue::parse("# nothing\n", "empty.txt");
  ASSERT_FALSE(empty);
  EXPECT_NE(empty.error().find("empty.txt: no stars"), std::string::npos);
  const auto missing = StarCatalogue::open("/nonexistent/stars.txt");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().find("/nonexistent/stars.txt"), std::string::npos);
}

TEST(StarCatalogue, PolarisStaysByTheNorthPoleThisCentury) {
  const Star& polaris = *bundled().find(11767);
  const glm::dvec3 z{0.0, 0.0, 1.0};
  // J2000 place: 0.736 degree from the pole; precession brings it nearer until 2100.
  for (int year = 2000; year <= 2100; year += 5)
    for (const double hours : {0.0, 5.0, 13.0, 21.5}) {
      const double a = angleDeg(starDirectionEcef(polaris, unixOf(year, 3, 20, hours)), z);
      EXPECT_LT(a, 0.75) << year;
      EXPECT_GT(a, 0.44) << year;
    }
}

TEST(StarCatalogueExtremes, PolarisFarFromJ2000MatchesPrecession) {
  // Polaris's declination of date: 88 deg 46.4' in 1900.0 and its closest, 89 deg 32.8', about
  // 2100 March (Meeus, "Astronomical Algorithms", ch. 21 and "Mathematical Astronomy Morsels").
  // Proper motion (0.04"/yr) and nutation (< 17") are left out: within 0.02 degree.
  const Star& polaris = *bundled().find(11767);
  const glm::dvec3 z{0.0, 0.0, 1.0};
  EXPECT_NEAR(angleDeg(starDirectionEcef(polaris, unixOf(1900, 1, 1)), z), 1.2267, 0.02);
  EXPECT_NEAR(angleDeg(starDirectionEcef(polaris, unixOf(2100, 3, 24)), z), 0.4533, 0.02);
  // Far from J2000 the placement stays a rotation (unit vectors, finite).
  for (const double t : {unixOf(1600, 1, 1), unixOf(2600, 6, 1), 0.0, -1e10, 1e10})
    for (const Star& s : {bundled().stars()[0], polaris}) {
      const glm::dvec3 d = starDirectionEcef(s, t);
      EXPECT_NEAR(glm::length(d), 1.0, 1e-12);
    }
}

TEST(StarCatalogueExtremes, PolesAndTheZeroMeridianOfRightAscension) {
  // A star at the J2000 pole sits at precession's pole of J2000, near +z for centuries; RA 0 and
  // RA 359.9999 are neighbours, 0.0001 degree apart on the equator.
  const Star north{.hip = 1, .raRad = 0.0, .decRad = std::numbers::pi / 2, .vmag = 1.0, .bv = {}};
  const Star south{.hip = 2, .raRad = 0.0, .decRad = -std::numbers::pi / 2, .vmag = 1.0, .bv = {}};
  const double t = unixOf(2026, 12, 2);
  EXPECT_NEAR(angleDeg(starDirectionEcef(north, t), {0, 0, 1}), 0.0, 0.2); // 50"/yr x 27 yr
  EXPECT_NEAR(angleDeg(starDirectionEcef(south, t), {0, 0, -1}), 0.0, 0.2);
  const Star a{.hip = 3, .raRad = 0.0, .decRad = 0.0, .vmag = 1.0, .bv = {}};
  const Star b{.hip = 4, .raRad = 359.9999 * kDeg, .decRad = 0.0, .vmag = 1.0, .bv = {}};
  EXPECT_NEAR(angleDeg(starDirectionEcef(a, t), starDirectionEcef(b, t)), 1e-4, 1e-9);
}

TEST(StarCatalogue, TheSkyTurnsOncePerSiderealDayAboutTheAxis) {
  const Star& betelgeuse = *bundled().find(27989);
  const double t0 = unixOf(2026, 12, 2, 3.0);
  const glm::dvec3 d0 = starDirectionEcef(betelgeuse, t0);
  // After one sidereal day the same direction (precession adds 0.14" a day).
  EXPECT_LT(angleDeg(d0, starDirectionEcef(betelgeuse, t0 + kSiderealDayS)), 1e-4);
  // After one solar day it is 0.9856 degree further west (the sun's motion a day).
  EXPECT_NEAR(angleDeg(d0, starDirectionEcef(betelgeuse, t0 + 86400.0)) /
                  std::cos(betelgeuse.decRad),
              360.0 * (86400.0 / kSiderealDayS - 1.0),
              1e-3);
  // Westward (the Earth turns east): ECEF longitude falls by 15.041 degrees an hour.
  for (int hour = 1; hour <= 24; ++hour) {
    const glm::dvec3 d = starDirectionEcef(betelgeuse, t0 + hour * 3600.0);
    double turned = (std::atan2(d0.y, d0.x) - std::atan2(d.y, d.x)) / kDeg;
    turned = std::fmod(turned + 720.0, 360.0);
    const double expected = std::fmod(hour * 3600.0 / kSiderealDayS * 360.0, 360.0);
    EXPECT_NEAR(std::remainder(turned - expected, 360.0), 0.0, 1e-3) << hour;
    EXPECT_NEAR(d.z, d0.z, 1e-7); // the declination holds (precession: 1e-8 a day)
  }
}

TEST(StarCatalogue, EnergyFollowsMagnitudeThroughTheDisplayGammaUpToTheCap) {
  // 5.5 magnitudes (2.5 x 2.2) is a factor of 10 in energy.
  EXPECT_NEAR(starEnergy(5.5, 1.0) / starEnergy(0.0, 1.0), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(starEnergy(0.0, 1.0), kStarEnergyMag0);
  EXPECT_GT(starEnergy(-1.46, 1.0), starEnergy(0.42, 1.0)); // Sirius over Betelgeuse
  EXPECT_LT(starEnergy(-1.46, 1.0), kStarEnergyCap);        // not capped by default
  EXPECT_DOUBLE_EQ(starEnergy(-1.46, 10.0), kStarEnergyCap);
  EXPECT_DOUBLE_EQ(starEnergy(3.0, 2.0), 2.0 * starEnergy(3.0, 1.0));
  EXPECT_EQ(starEnergy(1.0, 0.0), 0.0);
  EXPECT_EQ(starEnergy(NAN, 1.0), 0.0);
  EXPECT_NEAR(kStarEnergyCap, 2.0 * std::numbers::pi * 0.64, 1e-12);
}

TEST(StarCatalogue, ColourFromBMinusV) {
  EXPECT_NEAR(starTemperatureK(0.65), 5778.0, 30.0); // the sun
  // Vega (B-V 0.00) is 9,600 K; the fit gives 10,125 K (5%: invisible in the colour).
  EXPECT_NEAR(starTemperatureK(0.0), 9600.0, 600.0);
  const auto blue = starColour(-0.3), sun = starColour(0.65), red = starColour(1.85),
             white = starColour(std::nullopt);
  EXPECT_DOUBLE_EQ(blue[2], 1.0);
  EXPECT_LT(blue[0], 0.8);
  EXPECT_DOUBLE_EQ(red[0], 1.0);
  EXPECT_LT(red[2], 0.6);
  EXPECT_GT(sun[2], 0.8); // near white, a little warm
  EXPECT_DOUBLE_EQ(sun[0], 1.0);
  EXPECT_EQ(white, (std::array<double, 3>{1.0, 1.0, 1.0}));
  for (const double bv : {-1.0, -0.4, 0.3, 1.0, 2.0, 3.5})
    for (const double c : starColour(bv)) {
      EXPECT_GE(c, 0.0) << bv;
      EXPECT_LE(c, 1.0) << bv;
    }
}

} // namespace
