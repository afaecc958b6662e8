# cmake -DOUTPUT=<header> -DINPUTS=<a;b;...> -P EmbedShaders.cmake
# Writes a header with one `inline constexpr const char* kShader_<name>` per GLSL file (the name's
# dots become underscores), so the renderer needs no files at run time.
set(text "// Generated from shaders/ by cmake/EmbedShaders.cmake; do not edit.\n#pragma once\n\n")
foreach(input IN LISTS INPUTS)
  get_filename_component(name "${input}" NAME)
  string(REPLACE "." "_" name "${name}")
  file(READ "${input}" source)
  string(APPEND text "inline constexpr const char* kShader_${name} = R\"glsl(${source})glsl\";\n\n")
endforeach()
file(WRITE "${OUTPUT}.tmp" "${text}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
