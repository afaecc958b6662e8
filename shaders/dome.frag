// The dome's warp pass: an angular fisheye (azimuthal equidistant) domemaster from the cube of
// faces. The mesh gives each fragment its direction (theta = radius x half-FOV from the axis);
// the cube map is sampled with seamless filtering across face borders. Outside the circle (the
// mesh reaches a pixel beyond it): black.
uniform samplerCube uCube;
uniform vec3 uCircle; // centre x, y and radius in window pixels
in vec3 vDirection;
out vec4 fragColor;

void main() {
  if (length(gl_FragCoord.xy - uCircle.xy) > uCircle.z) {
    fragColor = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  fragColor = vec4(texture(uCube, vDirection).rgb, 1.0);
}
