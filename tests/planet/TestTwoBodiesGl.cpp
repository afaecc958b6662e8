// The Earth and the Moon in one scene (issue 26, label gl; planet/SceneBodies.hpp,
// planet/gl/src/BodiesPass.hpp): the Moon's disc where the ephemeris and the pinhole camera put
// it, of the size they give, lit from the same side as the Earth; a descent to 1 m above the
// Moon with the Earth in view, and no jitter there (mirroring RenderGl.NoJitterOneMetreAboveThe-
// Ground: 1 cm steps move the ground by the same amount each, and the Earth not at all).

#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/SceneBodies.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;
using astro::EphemerisBody;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kFirstQuarter2024 = 1705549920.0; // 2024-01-18 03:52 UTC: the Moon half lit
constexpr GridSpec kGrid{Sector{}, 36.0, 32, 32, 3};

FakeTileSource::Layer flatLayer(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kGrid.tileWidth * kGrid.tileHeight * 4));
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = r;
    px[i + 1] = g;
    px[i + 2] = b;
    px[i + 3] = 255;
  }
  return {"flat",
          kGrid,
          "image/png",
          FakeTileSource::bytes(encodePngRgba(kGrid.tileWidth, kGrid.tileHeight, px), "image/png")};
}

RendererOptions::SceneBody
flatBody(const Body& body, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  return {body, {}, {r, g, b}};
}

struct Px {
  const std::vector<std::uint8_t>& p;
  int w;
  const std::uint8_t* at(int x, int y) const {
    return &p[static_cast<std::size_t>((y * w + x) * 4)];
  }
};

/** A disc found in a window: its pixels' centroid (image pixels, rows from the top), the radius
 * of a disc of its area, and its lit part's centroid. */
struct Disc {
  int n = 0;
  glm::dvec2 centre{0.0};
  double radius = 0.0;
  glm::dvec2 litCentre{0.0};
};

template <class Is>
Disc findDisc(const Px& px, int h, glm::dvec2 around, double half, Is is, int litAbove) {
  Disc d;
  int lit = 0;
  for (int y = std::max(0, int(around.y - half)); y < std::min(h, int(around.y + half)); ++y)
    for (int x = std::max(0, int(around.x - half)); x < std::min(px.w, int(around.x + half)); ++x) {
      const std::uint8_t* c = px.at(x, y);
      if (!is(c)) continue;
      ++d.n;
      d.centre += glm::dvec2(x + 0.5, y + 0.5);
      if (std::max({c[0], c[1], c[2]}) > litAbove) {
        ++lit;
        d.litCentre += glm::dvec2(x + 0.5, y + 0.5);
      }
    }
  if (d.n > 0) d.centre /= d.n;
  if (lit > 0) d.litCentre /= lit;
  d.radius = std::sqrt(d.n / std::numbers::pi);
  return d;
}

/** The radius in pixels of a disc of the same area as a sphere of radius r centred at `c`
 * projects to: f tan(asin(r / d)) on the axis; off it, at angle theta, an ellipse stretched by
 * 1 / cos^2 theta radially and 1 / cos theta across (their geometric mean, 1 / cos^1.5). */
double discRadiusPx(const Camera& cam, const glm::dvec3& c, double r, double f) {
  const glm::dvec3 to = c - cam.position();
  const double d = glm::length(to);
  const double cosTheta = glm::dot(to / d, cam.forward());
  return f * std::tan(std::asin(r / d)) / std::pow(cosTheta, 1.5);
}

/** Image pixel (rows from the top) of a point in the scene's frame. */
glm::dvec2 imageOf(const Camera& cam, const glm::dvec3& p, int w, int h) {
  glm::dvec2 c;
  EXPECT_TRUE(cam.projectPx(p, c));
  return {w / 2.0 + c.x, h / 2.0 - c.y};
}

} // namespace

// From 420,000 km beyond the Moon looking back at the Earth, 2024-01-18 03:52 UTC (first quarter):
// the Moon's disc is where the ephemeris puts it through the pinhole projection and of its
// angular size, within a pixel, and both discs are lit from the side the sun is on.
TEST(TwoBodiesGl, TheMoonIsWhereTheEphemerisPutsItLitLikeTheEarth) {
  const double t = kFirstQuarter2024;
  const Geodesy earth; // WGS84
  FakeTileSource source(flatLayer(40, 90, 220));
  RendererOptions o;
  o.layer = "flat";
  o.width = 512;
  o.height = 512;
  o.verticalFovDeg = 10.0;
  o.timeUnixSeconds = t;
  o.sunlight = true;
  o.sceneBodies = {flatBody(moonBody(), 230, 230, 230)};
  // The camera 800,000 km out, 4 degrees off the Moon's direction, looking down at the Earth.
  const glm::dvec3 moon = placeBody(EphemerisBody::earth, EphemerisBody::moon, t).centre;
  const glm::dvec3 m = glm::normalize(moon);
  const glm::dvec3 side = glm::normalize(glm::cross(m, glm::dvec3(0.0, 0.0, 1.0)));
  const glm::dvec3 u = std::cos(4.0 * kDeg) * m + std::sin(4.0 * kDeg) * side;
  const glm::dvec3 at = 8.0e8 * u;
  const Geodetic g = earth.fromEcef({at.x, at.y, at.z});
  const CameraPose pose{g.latDeg, g.lonDeg, g.heightM, 0.0, 0.0};
  OPEN_RENDERER(r, source, earth, o);
  const Rendered out = renderComplete(r, pose);
  ASSERT_TRUE(out.complete);
  const Camera cam = r.camera(r.drawnPose());
  const Px px{out.pixels, o.width};
  const glm::dvec2 moonAt = imageOf(cam, moon, o.width, o.height);
  const glm::dvec2 earthAt = imageOf(cam, glm::dvec3(0.0), o.width, o.height);
  const double f = o.height / 2.0 / std::tan(o.verticalFovDeg / 2.0 * kDeg);
  const double moonR = discRadiusPx(cam, moon, moonBody().radiusA, f);
  const double earthR = discRadiusPx(cam, glm::dvec3(0.0), 6371000.0, f);
  ASSERT_GT(glm::length(moonAt - earthAt), 3.0 * (moonR + earthR)) << "the discs are apart";
  // Grey (the Moon) against blue (the Earth); the night sides keep the ambient light.
  const auto grey = [](const std::uint8_t* c) { return c[0] > 1 && c[0] == c[2]; };
  const auto blue = [](const std::uint8_t* c) { return c[2] > 1 && c[2] > c[0]; };
  const Disc md = findDisc(px, o.height, moonAt, 3.0 * moonR, grey, 40);
  const Disc ed = findDisc(px, o.height, earthAt, 3.0 * earthR, blue, 40);
  std::printf("moon: predicted (%.2f, %.2f) r %.2f, drawn (%.2f, %.2f) r %.2f; earth: predicted "
              "(%.2f, %.2f) r %.2f, drawn (%.2f, %.2f) r %.2f\n",
              moonAt.x,
              moonAt.y,
              moonR,
              md.centre.x,
              md.centre.y,
              md.radius,
              earthAt.x,
              earthAt.y,
              earthR,
              ed.centre.x,
              ed.centre.y,
              ed.radius);
  ASSERT_GT(md.n, 100);
  EXPECT_NEAR(md.centre.x, moonAt.x, 1.0);
  EXPECT_NEAR(md.centre.y, moonAt.y, 1.0);
  EXPECT_NEAR(md.radius, moonR, 0.5);
  EXPECT_NEAR(ed.radius, earthR, 0.5);
  // The sun's side of each disc in the image: a point a radius sunward of each centre, projected.
  const glm::dvec3 sun = astro::sunDirectionEcef(t);
  const glm::dvec2 moonSun = imageOf(cam, moon + 1.0e6 * sun, o.width, o.height) - moonAt;
  const glm::dvec2 earthSun = imageOf(cam, 1.0e6 * sun, o.width, o.height) - earthAt;
  const glm::dvec2 moonLit = md.litCentre - md.centre, earthLit = ed.litCentre - ed.centre;
  std::printf("lit side: moon (%.2f, %.2f) earth (%.2f, %.2f); sunward (%.2f, %.2f)\n",
              moonLit.x,
              moonLit.y,
              earthLit.x,
              earthLit.y,
              moonSun.x,
              moonSun.y);
  EXPECT_GT(glm::length(moonLit), 0.2 * moonR) << "the Moon is half lit";
  EXPECT_GT(glm::dot(glm::normalize(moonLit), glm::normalize(moonSun)), 0.9);
  EXPECT_GT(glm::dot(glm::normalize(earthLit), glm::normalize(earthSun)), 0.9);
  EXPECT_GT(glm::dot(glm::normalize(moonLit), glm::normalize(earthLit)), 0.9);
}

// A descent from 1,000 km to 1 m above the Moon, looking towards the Earth (unlit, flat blue):
// the Earth's disc stays where the ephemeris puts it at every altitude; at 1 m, 1 cm steps east
// move the ground's ramp texture by even steps (the eye and every position camera-relative in
// double) and the Earth's disc, 384,000 km away, not at all.
TEST(TwoBodiesGl, ADescentToOneMetreAboveTheMoonWithTheEarthInViewDoesNotJitter) {
  const double t = kFirstQuarter2024;
  const Geodesy moonG(moonBody());
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 24}, 0, 0)); // blue 0
  RendererOptions o;
  o.layer = "ramp";
  o.width = 480;
  o.height = 360;
  o.verticalFovDeg = 60.0;
  o.timeUnixSeconds = t;
  o.sceneBodies = {flatBody(earthBody(), 0, 0, 255)};
  // A third of the way into a tile at every level (as RenderGl's test), ~68 degrees from the
  // sub-Earth point: the Earth some 20 degrees above the horizon.
  const double lat = -42.0, lon0 = 60.0;
  const glm::dvec3 earth = placeBody(EphemerisBody::moon, EphemerisBody::earth, t).centre;
  const Ecef p = moonG.toEcef(lat, lon0, 0.0);
  const Ecef n = moonG.surfaceNormal(lat, lon0);
  const glm::dvec3 up(n.x, n.y, n.z), here(p.x, p.y, p.z);
  const glm::dvec3 east = glm::normalize(glm::cross(glm::dvec3(0.0, 0.0, 1.0), up));
  const glm::dvec3 north = glm::cross(up, east);
  const glm::dvec3 d = glm::normalize(earth - here);
  const double elevation = std::asin(glm::dot(d, up)) / kDeg;
  const double heading = std::atan2(glm::dot(d, east), glm::dot(d, north)) / kDeg;
  ASSERT_GT(elevation, 8.0);
  ASSERT_LT(elevation, 35.0);
  const double tilt = 90.0 + elevation - 20.0; // the Earth 20 degrees above the view's centre
  OPEN_RENDERER(r, ramp, moonG, o);
  const auto isEarth = [](const std::uint8_t* c) { return c[2] > 128; };
  glm::dvec2 lastEarth{0.0};
  for (const double alt : {1.0e6, 1.0e4, 100.0, 1.0}) {
    const Rendered out = renderComplete(r, {lat, lon0, alt, heading, tilt}, 120.0);
    ASSERT_TRUE(out.complete) << alt;
    const Camera cam = r.camera(r.drawnPose());
    const glm::dvec2 want = imageOf(cam, earth, o.width, o.height);
    const Disc e = findDisc(Px{out.pixels, o.width}, o.height, want, 20.0, isEarth, 255);
    const double f = o.height / 2.0 / std::tan(o.verticalFovDeg / 2.0 * kDeg);
    const double rPx = discRadiusPx(cam, earth, 6371000.0, f);
    std::printf("altitude %.0f m: earth predicted (%.2f, %.2f) r %.2f, drawn (%.2f, %.2f) r %.2f, "
                "level %d\n",
                alt,
                want.x,
                want.y,
                rPx,
                e.centre.x,
                e.centre.y,
                e.radius,
                out.stats.maxLevel);
    ASSERT_GT(e.n, 30) << alt;
    EXPECT_NEAR(e.centre.x, want.x, 1.0) << alt;
    EXPECT_NEAR(e.centre.y, want.y, 1.0) << alt;
    EXPECT_NEAR(e.radius, rPx, 0.5) << alt;
    lastEarth = e.centre;
  }
  // At 1 m: 1 cm steps east. The ground under a fixed patch at the bottom of the view moves by the
  // same amount each step (pixels crossing a tile's edge, |step| > 20, left out), the Earth's disc
  // not at all.
  const double metre = 1.0 / (moonG.equatorialRadius() * std::cos(lat * kDeg) * kDeg);
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<glm::dvec2> earthAt;
  int level = 0;
  for (int k = 0; k < 6; ++k) {
    const Rendered out =
        renderComplete(r, {lat, lon0 + k * 0.01 * metre, 1.0, heading, tilt}, 120.0);
    ASSERT_TRUE(out.complete);
    level = out.stats.maxLevel;
    frames.push_back(out.pixels);
    earthAt.push_back(
        findDisc(Px{out.pixels, o.width}, o.height, lastEarth, 20.0, isEarth, 255).centre);
  }
  std::vector<double> steps;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    double sum = 0.0;
    int used = 0;
    for (int y = o.height - 48; y < o.height - 8; ++y)
      for (int x = o.width / 2 - 24; x < o.width / 2 + 24; ++x) {
        const double step = double(Px{frames[k], o.width}.at(x, y)[0]) -
                            double(Px{frames[k - 1], o.width}.at(x, y)[0]);
        if (std::abs(step) > 20.0) continue;
        sum += step;
        ++used;
      }
    ASSERT_GT(used, 1200);
    steps.push_back(sum / used);
    EXPECT_LT(glm::length(earthAt[k] - earthAt[k - 1]), 0.05) << "the Earth moved";
  }
  double mean = 0.0;
  for (const double s : steps)
    mean += s / static_cast<double>(steps.size());
  std::printf("level %d, ground steps:", level);
  for (const double s : steps)
    std::printf(" %.3f", s);
  std::printf("\n");
  EXPECT_GE(level, 16);
  EXPECT_GT(std::abs(mean), 0.1) << "1 cm steps do not move the ground";
  for (const double s : steps)
    EXPECT_TRUE(s / mean > 0.5 && s / mean < 1.5)
        << "uneven step " << s << " (mean " << mean << "): the image jitters";
}

// A body without an ephemeris cannot share a scene, nor can one be added to it: refused at create.
TEST(TwoBodiesGl, BodiesWithoutAnEphemerisAreRefused) {
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY";
  FakeTileSource source(flatLayer(40, 90, 220));
  Body vesta = moonBody();
  vesta.name = "vesta";
  RendererOptions o;
  o.layer = "flat";
  o.width = o.height = 64;
  o.sceneBodies = {flatBody(vesta, 1, 2, 3)};
  const Geodesy earth;
  auto made = Renderer::create(source, earth, o);
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().find("vesta"), std::string::npos);
  o.sceneBodies = {flatBody(moonBody(), 1, 2, 3)};
  const Geodesy v(vesta);
  made = Renderer::create(source, v, o);
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().find("vesta"), std::string::npos);
}
