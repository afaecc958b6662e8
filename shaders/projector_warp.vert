// A projector channel's warp and blend pass (issue 28; planet/gl/src/ProjectorWarp.hpp): one
// triangle over the whole projector image; the fragment shader does the rest. The renderer
// prepends #version.
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;
  gl_Position = vec4(p, 0.0, 1.0);
}
