#include "PlanetTestSupport.hpp"

#include <tellus/planet/Camera.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;
using tellus::planet::test::finite;

namespace {
void expectVecNear(const glm::dvec3& a, const glm::dvec3& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}
} // namespace

TEST(Camera, NadirOverEquatorFrame) {
  const Geodesy g;
  const Camera cam(g, {0.0, 0.0, 1e7, 0.0, 0.0}, {1024, 768});
  expectVecNear(cam.position(), {6378137.0 + 1e7, 0, 0}, 1e-6);
  expectVecNear(cam.forward(), {-1, 0, 0}, 1e-15);
  expectVecNear(cam.up(), {0, 0, 1}, 1e-15);    // north is up on screen
  expectVecNear(cam.right(), {0, 1, 0}, 1e-15); // east is right
  // The view matrix takes the camera to the origin and the Earth's centre to -z.
  const glm::dvec4 eye = cam.view() * glm::dvec4(cam.position(), 1.0);
  EXPECT_NEAR(glm::length(glm::dvec3(eye)), 0.0, 1e-6);
  const glm::dvec4 centre = cam.view() * glm::dvec4(0, 0, 0, 1);
  EXPECT_NEAR(centre.z, -(6378137.0 + 1e7), 1e-6);
}

TEST(Camera, HeadingAndTilt) {
  const Geodesy g;
  // At the equator, heading 90 (east) and tilt 90 (horizon): looking east along +y.
  const Camera east(g, {0.0, 0.0, 100.0, 90.0, 90.0}, {800, 600});
  expectVecNear(east.forward(), {0, 1, 0}, 1e-15);
  expectVecNear(east.up(), {1, 0, 0}, 1e-15);
  // Tilt 45 heading north at (0, 90): halfway between down (-y) and north (+z).
  const Camera t(g, {0.0, 90.0, 100.0, 0.0, 45.0}, {800, 600});
  expectVecNear(t.forward(), {0, -std::sqrt(0.5), std::sqrt(0.5)}, 1e-15);
  // Frames stay orthonormal.
  for (const Camera* c : {&east, &t}) {
    EXPECT_NEAR(glm::dot(c->forward(), c->up()), 0.0, 1e-15);
    EXPECT_NEAR(glm::dot(c->forward(), c->right()), 0.0, 1e-15);
    EXPECT_NEAR(glm::length(c->right()), 1.0, 1e-15);
  }
}

TEST(Camera, ReversedZInfiniteDepthResolvesOneMetreToABillionMetres) {
  const Geodesy g;
  const Camera cam(g, {10.0, 20.0, 1e9, 0.0, 0.0}, {1024, 768}, 45.0, 0.1);
  auto depth = [&](double d) {
    const glm::dvec4 clip = cam.toClip(cam.position() + d * cam.forward());
    return clip.z / clip.w;
  };
  // World-space clip coordinates 1e9 m from the origin cancel ~1e-7 m (the GL layer will be
  // camera-relative), hence the tolerance.
  EXPECT_NEAR(depth(0.1), 1.0, 1e-5); // near plane
  EXPECT_NEAR(depth(1.0), 0.1, 1e-6);
  EXPECT_NEAR(depth(1e9), 1e-10, 1e-14);
  // With a float32 depth buffer, 0.1 % in distance still gives distinct, ordered depths anywhere.
  for (double d = 1.0; d <= 1e9; d *= 1.7) {
    const auto a = static_cast<float>(depth(d));
    const auto b = static_cast<float>(depth(d * 1.001));
    EXPECT_GT(a, b) << "distance " << d;
    EXPECT_GT(b, 0.0f) << "distance " << d;
  }
}

TEST(Camera, FrustumPlanesAgreeWithProjection) {
  const Geodesy g;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const CameraPose pose : {CameraPose{0, 0, 1e7, 0, 0},
                                CameraPose{45, -120, 1000, 30, 70},
                                CameraPose{90, 0, 5, 0, 90},
                                CameraPose{-33, 180, 1e9, 200, 10}}) {
    const Camera cam(g, pose, {1024, 768}, 60.0, 0.5);
    int inside = 0, outside = 0;
    for (int i = 0; i < 4000; ++i) {
      const double dist = std::pow(10.0, 3.0 * (u(rng) + 1.0)); // 1 m .. 1e6 m
      const glm::dvec3 dir = glm::normalize(glm::dvec3(u(rng), u(rng), u(rng)) + cam.forward());
      const glm::dvec3 p = cam.position() + dist * dir;
      const glm::dvec4 clip = cam.toClip(p);
      const bool projIn =
          clip.w >= cam.nearM() && std::abs(clip.x) <= clip.w && std::abs(clip.y) <= clip.w;
      // Skip points within 1e-9 (relative) of a boundary.
      const double slack = 1e-9 * clip.w;
      const bool clear = std::abs(clip.w - cam.nearM()) > 1e-9 &&
                         std::abs(std::abs(clip.x) - clip.w) > slack &&
                         std::abs(std::abs(clip.y) - clip.w) > slack;
      if (!clear) continue;
      EXPECT_EQ(test::inFrustum(cam, p), projIn) << "point " << i;
      (projIn ? inside : outside)++;
    }
    EXPECT_GT(inside, 100);
    EXPECT_GT(outside, 100);
    for (const Plane& pl : cam.frustum().planes) {
      EXPECT_NEAR(glm::length(pl.n), 1.0, 1e-12);
      EXPECT_TRUE(std::isfinite(pl.d));
    }
    // The near plane's normal is the view direction.
    EXPECT_NEAR(glm::dot(cam.frustum().planes[Frustum::Near].n, cam.forward()), 1.0, 1e-12);
  }
}

TEST(Camera, RejectsInvalidInput) {
  const Geodesy g;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Camera(g, {90.5, 0, 1, 0, 0}, {10, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {nan, 0, 1, 0, 0}, {10, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, inf, 1, 0, 0}, {10, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, 0, nan, 0, 0}, {10, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, 0, 1, 0, -1}, {10, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, 0, 1, 0, 0}, {0, 10}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, 0, 1, 0, 0}, {10, 10}, 180.0), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0, 0, 1, 0, 0}, {10, 10}, 45.0, 0.0), std::invalid_argument);
  EXPECT_NO_THROW(Camera(g, {-90, -180, -500, 0, 180}, {1, 1}));
}

TEST(CameraExtremes, AllOutputsFiniteOverASweep) {
  const Geodesy g;
  int cameras = 0;
  for (const double lat : {-90.0, -89.9999999, -45.0, -0.0, 0.0, 60.0, 89.9999999, 90.0})
    for (const double lon : {-180.0, -179.9999999, -0.0, 0.0, 179.9999999, 180.0})
      for (const double alt : {-500.0, 0.0, 1.0, 10.0, 1e4, 2e7, 1e9})
        for (const double tilt : {0.0, 45.0, 90.0, 180.0})
          for (const double heading : {0.0, 90.0, -180.0, 359.9}) {
            const Camera cam(g, {lat, lon, alt, heading, tilt}, {1024, 768});
            ++cameras;
            ASSERT_TRUE(finite(cam.position()));
            ASSERT_TRUE(finite(cam.forward()) && finite(cam.up()) && finite(cam.right()));
            ASSERT_NEAR(glm::length(cam.forward()), 1.0, 1e-12);
            for (int c = 0; c < 4; ++c)
              for (int r = 0; r < 4; ++r) {
                ASSERT_TRUE(std::isfinite(cam.viewProjection()[c][r]));
              }
            for (const Plane& pl : cam.frustum().planes) {
              ASSERT_TRUE(finite(pl.n) && std::isfinite(pl.d));
            }
          }
  EXPECT_EQ(cameras, 8 * 6 * 7 * 4 * 4);
}

// A turned camera (a dome's projector channel, issue 28) given the geodesy sees the same ground
// through its viewport as the perspective camera of the same frame; without, none.
TEST(Camera, TurnedCameraCastsItsViewportGround) {
  const Geodesy g;
  const Camera cam(g, {10.0, 20.0, 3000.0, 30.0, 60.0}, {400, 300}, 50.0);
  const Camera turned(cam, cam.forward(), cam.up(), {400, 300}, 50.0, &g);
  const Camera bare(cam, cam.forward(), cam.up(), {400, 300}, 50.0);
  for (std::size_t i = 0; i < cam.viewportGround().size(); ++i) {
    EXPECT_EQ(turned.viewportGround()[i].hit, cam.viewportGround()[i].hit);
    EXPECT_NEAR(turned.viewportGround()[i].latDeg, cam.viewportGround()[i].latDeg, 1e-9);
    EXPECT_NEAR(turned.viewportGround()[i].lonDeg, cam.viewportGround()[i].lonDeg, 1e-9);
    EXPECT_FALSE(bare.viewportGround()[i].hit);
  }
  EXPECT_TRUE(cam.viewportGround()[4].hit); // the bottom edge sees the ground
}
