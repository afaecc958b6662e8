// The dome's warp pass: a polygon of kSegments sides around the image's circle (a triangle fan,
// no vertex buffer: gl_VertexID; vertex 0 is the centre), drawn over the black the pass cleared
// to, so that only pixels in the circle run the warp. The renderer prepends #version.
uniform vec3 uCircle;  // centre x, y and radius in window pixels
uniform vec2 uViewport; // width, height in pixels
const int kSegments = 256;

void main() {
  vec2 p = uCircle.xy;
  if (gl_VertexID > 0) {
    // The polygon around the circle: its edges' midpoints lie on a circle one pixel larger.
    float a = 6.28318530718 * float(gl_VertexID - 1) / float(kSegments);
    float r = (uCircle.z + 1.0) / cos(3.14159265359 / float(kSegments));
    p += r * vec2(cos(a), sin(a));
  }
  gl_Position = vec4(p / uViewport * 2.0 - 1.0, 0.0, 1.0);
}
