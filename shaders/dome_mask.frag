// The direct dome's mask: exact black where a pixel's centre lies beyond the circle (the same
// test as the cube method's warp, dome.frag), the scene left as it is within it.
uniform vec3 uCircle; // centre x, y and radius in window pixels
out vec4 fragColor;

void main() {
  if (length(gl_FragCoord.xy - uCircle.xy) <= uCircle.z) discard;
  fragColor = vec4(0.0, 0.0, 0.0, 1.0);
}
