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

/** A program from a vertex and a fragment shader; 0 with error set when either fails. */
inline GLuint linkProgram(const std::string& vsSource,
                          const std::string& fsSource,
                          const char* what,
                          std::string* error) {
  const GLuint vs = compileShader(GL_VERTEX_SHADER, vsSource, what, error);
  if (vs == 0) return 0;
  const GLuint fs = compileShader(GL_FRAGMENT_SHADER, fsSource, what, error);
  if (fs == 0) {
    glDeleteShader(vs);
    return 0;
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint linked = GL_FALSE;
  glGetProgramiv(program, GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    char log[2048] = {};
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    glDeleteProgram(program);
    *error = std::string(what) + " link: " + log;
    return 0;
  }
  return program;
}

} // namespace tellus::planet
