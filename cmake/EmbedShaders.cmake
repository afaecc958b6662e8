# cmake -DOUTPUT=<header> -DINPUTS=<a;b;...> -P EmbedShaders.cmake
# Writes a header with one `inline constexpr const char* kShader_<name>` per GLSL file (the name's
# dots become underscores), so the renderer needs no files at run time. Each text starts with
# `#line 1 K` (K: the file's place in INPUTS, from 1; source string 0 is what the renderer prepends:
# #version and #defines), so a driver's message names the file's own line numbers, and
# kShaderFiles[K] names the file (planet/gl/src/GlShader.cpp adds that to compile errors).
set(text "// Generated from shaders/ by cmake/EmbedShaders.cmake; do not edit.\n#pragma once\n\n")
set(files "inline constexpr const char* kShaderFiles[] = {\n    \"(prepended lines)\",\n")
set(k 0)
foreach(input IN LISTS INPUTS)
  math(EXPR k "${k} + 1")
  get_filename_component(file "${input}" NAME)
  string(REPLACE "." "_" name "${file}")
  file(READ "${input}" source)
  string(APPEND text "inline constexpr const char* kShader_${name} = R\"glsl(#line 1 ${k}\n${source})glsl\";\n\n")
  string(APPEND files "    \"shaders/${file}\",\n")
endforeach()
string(APPEND text "${files}};\n")
file(WRITE "${OUTPUT}.tmp" "${text}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
