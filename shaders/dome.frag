// The dome's warp pass: an angular fisheye (azimuthal equidistant) domemaster from the cube of
// faces. A pixel at radius r (1 at the inscribed circle) and angle phi from the image's right
// looks theta = r x half-FOV from the axis; that direction, in the cube's frame (x right, y up,
// the axis along -z), samples the cube map (seamless filtering across face borders). Outside the
// circle: black.
uniform samplerCube uCube;
uniform float uHalfAngle; // radians
uniform vec3 uCircle;     // centre x, y (window pixels) and radius in pixels

out vec4 fragColor;

void main() {
  vec2 p = (gl_FragCoord.xy - uCircle.xy) / uCircle.z;
  float r = length(p);
  if (r > 1.0) {
    fragColor = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  float theta = r * uHalfAngle;
  vec2 around = r > 0.0 ? p / r : vec2(0.0);
  vec3 d = vec3(sin(theta) * around, -cos(theta));
  fragColor = vec4(texture(uCube, d).rgb, 1.0);
}
