// The draw phase (planet/gl/src/SceneDraw.hpp) with passes of the tests' own (the slot issue 23's
// stars and atmosphere go into): each scene is bound, cleared to the background with the depth
// conventions of Depth.hpp, then its passes draw in the order added, each given the frame's shared
// context; the cube dome draws them once per face its cone reaches, the direct dome once with the
// fisheye and the mask after them.

#include "../../planet/gl/src/SceneDraw.hpp"
#include "GlContextSupport.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

/** Clears a part of the target (a scissor box in pixels; empty: all) to a colour and records
 * what it was given. */
class ClearPass final : public ScenePass {
public:
  ClearPass(std::array<float, 3> colour,
            std::array<int, 4> box,
            std::vector<std::string>* order,
            const char* name)
      : colour_(colour), box_(box), order_(order), name_(name) {}
  const char* name() const noexcept override { return name_; }
  void draw(const FrameContext& frame) override {
    order_->push_back(name_);
    targets.push_back(frame.target);
    fisheye.push_back(frame.fisheye != nullptr);
    viewProjection = frame.viewProjection;
    eye = frame.eye;
    sun = frame.sun.has_value();
    GLint func = 0;
    glGetIntegerv(GL_DEPTH_FUNC, &func);
    depthFunc = func;
    depthTest = glIsEnabled(GL_DEPTH_TEST) == GL_TRUE;
    const bool scissored = glIsEnabled(GL_SCISSOR_TEST) == GL_TRUE;
    if (box_[2] > 0) {
      glEnable(GL_SCISSOR_TEST);
      glScissor(box_[0], box_[1], box_[2], box_[3]);
    }
    glClearColor(colour_[0], colour_[1], colour_[2], 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    if (box_[2] > 0 && !scissored) glDisable(GL_SCISSOR_TEST);
  }
  std::vector<DrawTarget> targets;
  std::vector<bool> fisheye;
  glm::mat4 viewProjection{0.0f};
  glm::dvec3 eye{0.0};
  bool sun = false;
  GLint depthFunc = 0;
  bool depthTest = false;

private:
  std::array<float, 3> colour_;
  std::array<int, 4> box_;
  std::vector<std::string>* order_;
  const char* name_;
};

std::array<int, 3> pixel(const std::vector<std::uint8_t>& rgba, int w, int x, int y) {
  const auto* p = &rgba[static_cast<std::size_t>((y * w + x) * 4)];
  return {p[0], p[1], p[2]};
}

RendererOptions sized(int w, int h) {
  RendererOptions o;
  o.width = w;
  o.height = h;
  o.background = {0.0, 0.0, 1.0};
  return o;
}

} // namespace

TEST(SceneDrawGl, PassesDrawInTheOrderAddedOverTheBackgroundWithTheFramesContext) {
  OPEN_GL_CONTEXT(context);
  const Geodesy geodesy;
  RendererOptions o = sized(64, 48);
  o.sunLatLon = std::array<double, 2>{10.0, 20.0};
  SceneDraw scene(o, geodesy, context.capabilities());
  std::vector<std::string> order;
  auto first = std::make_unique<ClearPass>(
      std::array<float, 3>{1, 0, 0}, std::array<int, 4>{0, 0, 32, 48}, &order, "left");
  auto second = std::make_unique<ClearPass>(
      std::array<float, 3>{0, 1, 0}, std::array<int, 4>{0, 24, 64, 24}, &order, "top");
  ClearPass& seen = *first;
  scene.addPass(std::move(first));
  scene.addPass(std::move(second));
  ASSERT_EQ(scene.passes().size(), 2u);
  EXPECT_STREQ(scene.passes()[1]->name(), "top");
  const Camera cam(geodesy, CameraPose{10.0, 20.0, 1e7}, Viewport{64, 48});
  RenderStats stats;
  scene.drawFrame(cam, DrawList{}, {}, 0.0, stats);
  EXPECT_EQ(order, (std::vector<std::string>{"left", "top"}));
  ASSERT_EQ(seen.targets.size(), 1u);
  EXPECT_EQ(seen.targets[0].fbo, scene.framebuffer().id());
  EXPECT_EQ(seen.targets[0].width, 64);
  EXPECT_EQ(seen.targets[0].frustum, nullptr);
  EXPECT_FALSE(seen.fisheye[0]);
  EXPECT_EQ(seen.viewProjection, eyeCentredViewProjection(cam));
  EXPECT_EQ(seen.eye, cam.position());
  EXPECT_TRUE(seen.sun);
  if (context.capabilities().clipControl) {
    EXPECT_EQ(seen.depthFunc, GLint{GL_GREATER});
  }
  EXPECT_TRUE(seen.depthTest);
  const auto px = scene.framebuffer().readPixels(); // rows from the top
  EXPECT_EQ(pixel(px, 64, 5, 40), (std::array<int, 3>{255, 0, 0})) << "bottom left: the first";
  EXPECT_EQ(pixel(px, 64, 5, 5), (std::array<int, 3>{0, 255, 0})) << "top: the second over it";
  EXPECT_EQ(pixel(px, 64, 60, 40), (std::array<int, 3>{0, 0, 255})) << "the background";
  EXPECT_EQ(stats.domeMethod, "");
}

TEST(SceneDrawGl, TheCubeDomeDrawsThePassesOncePerFaceAndWarpsThemIntoTheCircle) {
  OPEN_GL_CONTEXT(context);
  const Geodesy geodesy;
  RendererOptions o = sized(64, 64);
  o.dome = DomeOptions{.fovDeg = 180.0, .method = DomeMethod::Cube};
  SceneDraw scene(o, geodesy, context.capabilities());
  ASSERT_TRUE(scene.openDome().has_value());
  std::vector<std::string> order;
  auto pass = std::make_unique<ClearPass>(
      std::array<float, 3>{1, 0, 0}, std::array<int, 4>{0, 0, 0, 0}, &order, "red");
  ClearPass& seen = *pass;
  scene.addPass(std::move(pass));
  const Camera fisheye(geodesy, CameraPose{45.0, 7.0, 5e5, 0.0, 90.0}, 64, Fisheye{180.0, 0.0});
  RenderStats stats;
  scene.drawFrame(fisheye, DrawList{}, {}, 0.0, stats);
  EXPECT_EQ(stats.domeMethod, "cube");
  EXPECT_EQ(seen.targets.size(), 5u) << "a 180-degree cone reaches five faces";
  for (const DrawTarget& t : seen.targets) {
    EXPECT_NE(t.frustum, nullptr);
    EXPECT_NE(t.fbo, scene.framebuffer().id());
    EXPECT_EQ(t.width, scene.dome()->faceSize());
  }
  EXPECT_EQ(stats.domeFaceBytes, Dome::bytesOfFaces(scene.dome()->faceSize()));
  const auto px = scene.framebuffer().readPixels();
  EXPECT_EQ(pixel(px, 64, 32, 32), (std::array<int, 3>{255, 0, 0}));
  EXPECT_EQ(pixel(px, 64, 0, 0), (std::array<int, 3>{0, 0, 0})) << "outside the circle";
}

TEST(SceneDrawGl, TheDirectDomeDrawsThePassesOnceWithTheFisheyeThenMasksTheCorners) {
  OPEN_GL_CONTEXT(context);
  const Geodesy geodesy;
  RendererOptions o = sized(64, 64);
  o.dome = DomeOptions{.fovDeg = 180.0, .method = DomeMethod::Direct};
  SceneDraw scene(o, geodesy, context.capabilities());
  ASSERT_TRUE(scene.openDome().has_value());
  std::vector<std::string> order;
  auto pass = std::make_unique<ClearPass>(
      std::array<float, 3>{1, 0, 0}, std::array<int, 4>{0, 0, 0, 0}, &order, "red");
  ClearPass& seen = *pass;
  scene.addPass(std::move(pass));
  const Camera fisheye(geodesy, CameraPose{45.0, 7.0, 5e5, 0.0, 90.0}, 64, Fisheye{180.0, 0.0});
  RenderStats stats;
  scene.drawFrame(fisheye, DrawList{}, {}, 0.0, stats); // nothing drawn: no straight-edge error
  EXPECT_EQ(stats.domeMethod, "direct");
  ASSERT_EQ(seen.targets.size(), 1u);
  EXPECT_TRUE(seen.fisheye[0]);
  EXPECT_EQ(seen.targets[0].fbo, scene.framebuffer().id());
  EXPECT_EQ(stats.domeFaceBytes, 0u) << "no faces made for the direct method";
  const auto px = scene.framebuffer().readPixels();
  EXPECT_EQ(pixel(px, 64, 32, 32), (std::array<int, 3>{255, 0, 0}));
  EXPECT_EQ(pixel(px, 64, 0, 0), (std::array<int, 3>{0, 0, 0})) << "the mask";
  EXPECT_EQ(pixel(px, 64, 63, 63), (std::array<int, 3>{0, 0, 0}));
}
