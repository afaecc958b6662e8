// The atmosphere pass (issue 23): one triangle that covers the viewport; the fragment shader
// finds each pixel's direction itself. The renderer prepends #version.
out vec2 vNdc; // the pixel's normalised device coordinates

void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  vNdc = p;
  gl_Position = vec4(p, 0.0, 1.0);
}
