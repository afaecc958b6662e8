#pragma once
/**
 * @file GlShader.hpp
 * @brief Compiling GLSL shaders and linking programs into owning handles (GlObjects.hpp), the GL's
 * log as the error.
 *
 * Line numbers: a source is the renderer's prepended lines (#version, #defines: source string 0)
 * followed by a file of shaders/ embedded at build time, which starts with `#line 1 K`
 * (cmake/EmbedShaders.cmake; K numbers the file), so a driver's message such as `1:12(3): error`
 * names the file's own line 12 in source string 1; the error ends with which file each source
 * string number is. Main thread, context current (GlObjects.hpp).
 */

#include "GlObjects.hpp"

#include <expected>
#include <string>

namespace tellus::planet {

/** A compiled shader, or `what: <the compiler's log>` (and the source strings' files). */
std::expected<GlShader, std::string>
compileShader(GLenum type, const std::string& source, const char* what);

/** A program from a vertex and a fragment shader, or `what: <log>` / `what link: <log>`. */
std::expected<GlProgram, std::string>
linkProgram(const std::string& vsSource, const std::string& fsSource, const char* what);

/** "\n(source string K: shaders/NAME ...)" for the `#line 1 K` markers in source (K > 0) whose
 * file cmake/EmbedShaders.cmake knows; "" when there are none. */
std::string shaderSourceLegend(const std::string& source);

} // namespace tellus::planet
