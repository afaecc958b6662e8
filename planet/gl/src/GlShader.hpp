#pragma once
// One GLSL shader compiled, for the renderer's programs (planet, dome): the GL's log as the error.

#include <epoxy/gl.h>

#include <string>

namespace tellus::planet {

/** A compiled shader, or 0 with *error = what + ": " + the compiler's log. The context must be
 * current. */
inline GLuint
compileShader(GLenum type, const std::string& source, const char* what, std::string* error) {
  const GLuint s = glCreateShader(type);
  const char* text = source.c_str();
  glShaderSource(s, 1, &text, nullptr);
  glCompileShader(s);
  GLint ok = GL_FALSE;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    *error = std::string(what) + ": " + log;
    glDeleteShader(s);
    return 0;
  }
  return s;
}

} // namespace tellus::planet
