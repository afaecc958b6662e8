// Owning handles of GL objects (planet/gl/src/GlObjects.hpp) and shader compilation with #line
// markers (GlShader.hpp): handles that own nothing need no context; handles that do create and
// delete their object, move it, give it up (release) and adopt one (wrap); a driver's error names
// the shader file and its own line.

#include "../../planet/gl/src/GlObjects.hpp"
#include "../../planet/gl/src/GlShader.hpp"
#include "GlContextSupport.hpp"
#include "Shaders.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>

using namespace tellus::planet;

TEST(GlObjects, HandlesThatOwnNothingNeedNoContext) {
  GlTexture a(NoCreate);
  EXPECT_EQ(a.id(), 0u);
  EXPECT_FALSE(a.created());
  GlTexture b = std::move(a);
  EXPECT_FALSE(b.created());
  b.reset();
  EXPECT_EQ(b.release(), 0u);
  // A name adopted and given up again is never deleted (no GL call: no context here).
  GlBuffer c = GlBuffer::wrap(42);
  EXPECT_TRUE(c.created());
  GlBuffer d = std::move(c);
  EXPECT_EQ(c.id(), 0u);
  EXPECT_EQ(d.id(), 42u);
  GlBuffer e(NoCreate);
  e = std::move(d); // e owned nothing: nothing deleted
  EXPECT_EQ(e.release(), 42u);
  EXPECT_FALSE(e.created());
  GlShader s(NoCreate);
  EXPECT_FALSE(s.created());
}

TEST(GlObjects, EveryEmbeddedShaderStartsWithItsLineMarker) {
  const std::string sources[] = {kShader_planet_vert,
                                 kShader_planet_frag,
                                 kShader_dome_vert,
                                 kShader_dome_frag,
                                 kShader_dome_mask_vert,
                                 kShader_dome_mask_frag};
  const std::string names[] = {
      "planet.vert", "planet.frag", "dome.vert", "dome.frag", "dome_mask.vert", "dome_mask.frag"};
  for (std::size_t i = 0; i < std::size(sources); ++i) {
    EXPECT_EQ(sources[i].rfind("#line 1 ", 0), 0u) << names[i];
    const std::string legend = shaderSourceLegend("#version 330 core\n" + sources[i]);
    EXPECT_NE(legend.find("shaders/" + names[i]), std::string::npos) << legend;
  }
  EXPECT_EQ(shaderSourceLegend("#version 330 core\nvoid main() {}\n"), "");
}

TEST(GlObjectsGl, HandlesCreateMoveReleaseAndDeleteTheirObjects) {
  OPEN_GL_CONTEXT(context);
  EXPECT_FALSE(context.capabilities().version.empty());
  GLuint name = 0;
  {
    GlTexture t;
    ASSERT_TRUE(t.created());
    glBindTexture(GL_TEXTURE_2D, t.id()); // a generated name is a texture once bound
    EXPECT_TRUE(glIsTexture(t.id()));
    name = t.id();
    GlTexture moved = std::move(t);
    EXPECT_EQ(moved.id(), name);
    EXPECT_FALSE(t.created());
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  EXPECT_FALSE(glIsTexture(name)) << "deleted with its handle";

  GlBuffer a, b;
  glBindBuffer(GL_ARRAY_BUFFER, a.id());
  glBindBuffer(GL_ARRAY_BUFFER, b.id());
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  const GLuint first = a.id();
  a = std::move(b); // deletes what a held
  EXPECT_FALSE(glIsBuffer(first));
  EXPECT_TRUE(glIsBuffer(a.id()));

  GLuint kept = 0;
  {
    GlFramebuffer f;
    glBindFramebuffer(GL_FRAMEBUFFER, f.id());
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    kept = f.release();
  }
  EXPECT_TRUE(glIsFramebuffer(kept)) << "released: the caller owns it";
  { const GlFramebuffer adopted = GlFramebuffer::wrap(kept); }
  EXPECT_FALSE(glIsFramebuffer(kept));

  GLuint program = 0, shader = 0, array = 0, renderbuffer = 0;
  {
    const GlProgram p;
    const GlShader s(GL_VERTEX_SHADER);
    const GlVertexArray v;
    const GlRenderbuffer r;
    glBindVertexArray(v.id());
    glBindVertexArray(0);
    glBindRenderbuffer(GL_RENDERBUFFER, r.id());
    glBindRenderbuffer(GL_RENDERBUFFER, 0);
    program = p.id();
    shader = s.id();
    array = v.id();
    renderbuffer = r.id();
    EXPECT_TRUE(glIsProgram(program) && glIsShader(shader) && glIsVertexArray(array) &&
                glIsRenderbuffer(renderbuffer));
  }
  EXPECT_FALSE(glIsProgram(program));
  EXPECT_FALSE(glIsShader(shader));
  EXPECT_FALSE(glIsVertexArray(array));
  EXPECT_FALSE(glIsRenderbuffer(renderbuffer));
  EXPECT_EQ(glGetError(), GLenum{GL_NO_ERROR});
}

TEST(GlObjectsGl, ACompileErrorNamesTheShaderFileAndItsOwnLine) {
  OPEN_GL_CONTEXT(context);
  const std::string header = context.capabilities().glslHeader() + "#define SOMETHING 1\n";
  // The embedded planet.frag with a mistake on its own line 3 (after two lines of the file).
  std::string source = kShader_planet_frag;
  std::size_t at = 0;
  for (int line = 0; line < 3; ++line)
    at = source.find('\n', at) + 1; // the marker, then the file's lines 1 and 2
  source.insert(at, "this is not GLSL;\n");
  const auto made = compileShader(GL_FRAGMENT_SHADER, header + source, "test shader");
  ASSERT_FALSE(made.has_value());
  const std::string& error = made.error();
  EXPECT_EQ(error.rfind("test shader: ", 0), 0u) << error;
  EXPECT_NE(error.find("source string 2: shaders/planet.frag"), std::string::npos) << error;
  EXPECT_NE(error.find("2:3("), std::string::npos) << "Mesa's string:line(column): " << error;
  const auto linked = linkProgram(header + kShader_dome_mask_vert, header + source, "test");
  ASSERT_FALSE(linked.has_value());
  const auto good = linkProgram(context.capabilities().glslHeader() + kShader_dome_mask_vert,
                                context.capabilities().glslHeader() + kShader_dome_mask_frag,
                                "dome mask");
  ASSERT_TRUE(good.has_value()) << good.error();
  EXPECT_TRUE(glIsProgram(good->id()));
}
