// The dome's warp pass: a polar mesh over the image's circle (rings of equal angle from the axis,
// segments around it), each vertex carrying its direction in the cube's frame (computed in double
// on the CPU: theta = radius x half-FOV), so a fragment only interpolates a direction and samples
// the cube. The renderer prepends #version.
layout(location = 0) in vec2 aPolar;     // the point in units of the circle's radius
layout(location = 1) in vec3 aDirection; // its direction, cube frame (x right, y up, axis -z)
uniform vec3 uCircle;                    // centre x, y and radius in window pixels
uniform vec2 uViewport;                  // width, height in pixels
out vec3 vDirection;

void main() {
  vDirection = aDirection;
  vec2 p = uCircle.xy + aPolar * uCircle.z;
  gl_Position = vec4(p / uViewport * 2.0 - 1.0, 0.0, 1.0);
}
