// Depth precision from 0.1 m to 1e9 m in one frustum (issue #8, "Precision at the extremes"), on
// the renderer's own depth conventions (planet/gl/src/Depth.hpp: 32-bit float depth, reversed Z
// through glClipControl, GL_GREATER) and its projection (Camera.hpp's reversed-Z infinite
// perspective with the near plane `Renderer::camera` uses 0.1 m above the ground), in the context
// a Renderer made. Eleven pairs of overlapping quads at 0.1, 1, 10, ... 1e9 m, each pair a front
// quad and one 1e-5 of its distance behind it covering the same pixels, drawn in one frame with one
// view-projection, the vertices eye-relative floats as planet.vert gets them: the front quad must
// win every pixel whichever is drawn first. The same scene through a conventional depth buffer
// (24-bit fixed point, [-1, 1] depth, near 0.1 m, far 1e10 m, GL_LESS) is drawn too and must fail,
// which shows the test can.

#include "Depth.hpp"
#include "GlShader.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <epoxy/gl.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

constexpr int kPairs = 11; // 0.1 m .. 1e9 m
constexpr int kColumn = 8, kHeight = 16, kWidth = kPairs * kColumn;
constexpr double kFovDeg = 45.0;
constexpr double kBehind = 1e-5; // the back quad's distance is d (1 + kBehind)

const char* kVert = R"(#version 330 core
layout(location = 0) in vec3 aPosition; // eye-relative, as planet.vert computes it
uniform mat4 uViewProj;
invariant gl_Position;
void main() { gl_Position = uViewProj * vec4(aPosition, 1.0); }
)";
const char* kFrag = R"(#version 330 core
uniform vec4 uColor;
out vec4 fragColor;
void main() { fragColor = uColor; }
)";

struct Wrong {
  std::array<int, kPairs> perPair{}; ///< pixels where the back quad shows, per distance
  int total = 0;
};

/** Draws the eleven pairs into a kWidth x kHeight framebuffer with the given depth setup and
 * counts the pixels that are not the front quad's red. */
Wrong drawPairs(GLenum depthFormat,
                const glm::dmat4& projection,
                const std::function<void()>& beginDepth) {
  auto linked = linkProgram(kVert, kFrag, "depth test program");
  EXPECT_TRUE(linked.has_value()) << linked.error();
  const GlProgram program = linked ? std::move(*linked) : GlProgram(NoCreate);

  const GlFramebuffer fbo;
  const GlRenderbuffer color, depth;
  glBindRenderbuffer(GL_RENDERBUFFER, color.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, kWidth, kHeight);
  glBindRenderbuffer(GL_RENDERBUFFER, depth.id());
  glRenderbufferStorage(GL_RENDERBUFFER, depthFormat, kWidth, kHeight);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo.id());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color.id());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id());
  EXPECT_EQ(glCheckFramebufferStatus(GL_FRAMEBUFFER), GLenum{GL_FRAMEBUFFER_COMPLETE});
  glViewport(0, 0, kWidth, kHeight);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glDisable(GL_SCISSOR_TEST);
  glDepthMask(GL_TRUE);
  beginDepth();
  glClearColor(0.0f, 0.0f, 1.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  // Quads in eye space covering their column's pixels (top or bottom half) at distance d: the
  // corners are the column's NDC rectangle pushed out to d along the view rays, in double, then
  // narrowed to float eye-relative positions.
  const double t = std::tan(kFovDeg * std::numbers::pi / 360.0);
  const double aspect = static_cast<double>(kWidth) / kHeight;
  const auto quad = [&](int pair, bool top, double d) {
    const double x0 = -1.0 + 2.0 * pair / kPairs, x1 = -1.0 + 2.0 * (pair + 1) / kPairs;
    const double y0 = top ? 0.0 : -1.0, y1 = top ? 1.0 : 0.0;
    std::vector<float> v;
    for (const auto& [x, y] : std::array<std::array<double, 2>, 6>{
             {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y0}, {x1, y1}, {x0, y1}}})
      v.insert(v.end(),
               {static_cast<float>(x * t * aspect * d),
                static_cast<float>(y * t * d),
                static_cast<float>(-d)});
    return v;
  };
  std::vector<float> front, back; // per pair: top half front first, bottom half back first
  std::vector<float> all;
  std::vector<std::array<float, 4>> colours;
  for (int i = 0; i < kPairs; ++i) {
    const double d = 0.1 * std::pow(10.0, i);
    for (const bool top : {true, false}) {
      const auto f = quad(i, top, d), b = quad(i, top, d * (1.0 + kBehind));
      if (top) {
        all.insert(all.end(), f.begin(), f.end());
        all.insert(all.end(), b.begin(), b.end());
        colours.push_back({1, 0, 0, 1});
        colours.push_back({0, 1, 0, 1});
      } else {
        all.insert(all.end(), b.begin(), b.end());
        all.insert(all.end(), f.begin(), f.end());
        colours.push_back({0, 1, 0, 1});
        colours.push_back({1, 0, 0, 1});
      }
    }
  }
  const GlVertexArray vao;
  const GlBuffer vbo;
  glBindVertexArray(vao.id());
  glBindBuffer(GL_ARRAY_BUFFER, vbo.id());
  glBufferData(GL_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(all.size() * sizeof(float)),
               all.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glUseProgram(program.id());
  const glm::mat4 viewProj(projection); // the eye at the origin looking down -z, as the renderer
  glUniformMatrix4fv(glGetUniformLocation(program.id(), "uViewProj"), 1, GL_FALSE, &viewProj[0][0]);
  const GLint uColor = glGetUniformLocation(program.id(), "uColor");
  for (std::size_t q = 0; q < colours.size(); ++q) {
    glUniform4fv(uColor, 1, colours[q].data());
    glDrawArrays(GL_TRIANGLES, static_cast<GLint>(q * 6), 6);
  }
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kWidth * kHeight * 4));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, kWidth, kHeight, GL_RGBA, GL_UNSIGNED_BYTE, px.data());

  Wrong w;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const std::uint8_t* p = &px[static_cast<std::size_t>((y * kWidth + x) * 4)];
      if (p[0] == 255 && p[1] == 0 && p[2] == 0) continue;
      ++w.perPair[static_cast<std::size_t>(x / kColumn)];
      ++w.total;
    }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return w; // the GL objects go with their handles
}

std::string describe(const Wrong& w) {
  std::string s;
  for (int i = 0; i < kPairs; ++i) {
    char b[48];
    std::snprintf(b,
                  sizeof b,
                  "%s%g m: %d",
                  i ? ", " : "",
                  0.1 * std::pow(10.0, i),
                  w.perPair[static_cast<std::size_t>(i)]);
    s += b;
  }
  return s;
}

} // namespace

TEST(DepthExtremesGl, DepthResolvesOneInAHundredThousandFromATenthOfAMetreToABillionMetres) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 4}, 8, 248));
  OPEN_RENDERER(r, ramp, geodesy, options("ramp", 32, 32)); // for its GL context
  ASSERT_TRUE(r.stats().reversedZ) << "no glClipControl: the renderer's depth is not reversed-Z";
  // The near plane the renderer uses 0.1 m above the ground (a 45-degree view): 0.1 m is in front.
  const double aspect = static_cast<double>(kWidth) / kHeight;
  const double nearM = nearDistanceFor(0.1, kFovDeg, aspect);
  ASSERT_LT(nearM, 0.1);
  const Wrong renderer =
      drawPairs(kDepthFormat,
                reversedZInfinitePerspective(kFovDeg * std::numbers::pi / 180.0, aspect, nearM),
                [] { beginReversedZ(true); });
  std::printf("reversed-Z float depth, near %.4f m: back quad pixels per distance: %s\n",
              nearM,
              describe(renderer).c_str());
  EXPECT_EQ(renderer.total, 0) << describe(renderer);

  // A conventional depth buffer over the same range fails (so this test can).
  const Wrong conventional =
      drawPairs(GL_DEPTH_COMPONENT24,
                glm::perspective(kFovDeg * std::numbers::pi / 180.0, aspect, nearM, 1e10),
                [] {
                  glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
                  glClearDepth(1.0);
                  glEnable(GL_DEPTH_TEST);
                  glDepthFunc(GL_LESS);
                });
  std::printf("24-bit [-1, 1] depth, near %.4f m, far 1e10 m: back quad pixels per distance: %s\n",
              nearM,
              describe(conventional).c_str());
  EXPECT_GT(conventional.total, 0) << "the conventional depth buffer resolved it too: the test "
                                      "cannot tell a good depth setup from a bad one";
  EXPECT_EQ(conventional.perPair[0], 0) << "even 0.1 m failed with the conventional buffer";
}
