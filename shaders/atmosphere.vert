// The atmosphere pass and its view tables (issue 23): one triangle that covers the viewport; the
// fragment shader finds each pixel's direction from vNdc (fisheye) or vRay (flat: the inverse
// view-projection is affine in NDC, so it is interpolated exactly). The renderer prepends
// #version.
out vec2 vNdc; // the pixel's normalised device coordinates
out vec4 vRay; // flat: uInvViewProj (NDC x, y, 1, 1): the ray up to the scale of w

uniform mat4 uInvViewProj;

void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  vNdc = p;
  vRay = uInvViewProj * vec4(p, 1.0, 1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
