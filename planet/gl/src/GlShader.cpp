#include "GlShader.hpp"

#include "Shaders.hpp"

#include <cstdlib>
#include <iterator>
#include <string_view>

namespace tellus::planet {

std::string shaderSourceLegend(const std::string& source) {
  std::string legend;
  constexpr std::string_view kMarker = "#line 1 ";
  for (std::size_t at = source.find(kMarker); at != std::string::npos;
       at = source.find(kMarker, at + 1)) {
    if (at != 0 && source[at - 1] != '\n') continue;
    const long k = std::strtol(source.c_str() + at + kMarker.size(), nullptr, 10);
    if (k <= 0 || k >= static_cast<long>(std::size(kShaderFiles))) continue;
    legend += legend.empty() ? "\n(" : ", ";
    legend += "source string " + std::to_string(k) + ": " + kShaderFiles[k];
  }
  return legend.empty() ? legend : legend + "; line numbers are the file's)";
}

std::expected<GlShader, std::string>
compileShader(GLenum type, const std::string& source, const char* what) {
  GlShader s(type);
  const char* text = source.c_str();
  glShaderSource(s.id(), 1, &text, nullptr);
  glCompileShader(s.id());
  GLint ok = GL_FALSE;
  glGetShaderiv(s.id(), GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {};
    glGetShaderInfoLog(s.id(), sizeof log, nullptr, log);
    return std::unexpected(std::string(what) + ": " + log + shaderSourceLegend(source));
  }
  return s;
}

std::expected<GlProgram, std::string>
linkProgram(const std::string& vsSource, const std::string& fsSource, const char* what) {
  auto vs = compileShader(GL_VERTEX_SHADER, vsSource, what);
  if (!vs) return std::unexpected(vs.error());
  auto fs = compileShader(GL_FRAGMENT_SHADER, fsSource, what);
  if (!fs) return std::unexpected(fs.error());
  GlProgram program;
  glAttachShader(program.id(), vs->id());
  glAttachShader(program.id(), fs->id());
  glLinkProgram(program.id());
  // The shaders go (flagged for deletion while attached) before the program's status is read, as
  // they always did.
  vs->reset();
  fs->reset();
  GLint linked = GL_FALSE;
  glGetProgramiv(program.id(), GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    char log[2048] = {};
    glGetProgramInfoLog(program.id(), sizeof log, nullptr, log);
    return std::unexpected(std::string(what) + " link: " + log);
  }
  return program;
}

} // namespace tellus::planet
