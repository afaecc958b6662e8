// The stars' footprint (planet/gl/src/StarsPass.hpp): a Gaussian of fixed width in pixels
// (uInvTwoSigma2 = 1 / (2 sigma^2), sigma = kStarSigmaPx) around the star's window position,
// sampled at the pixel's centre and added to the framebuffer (blending ONE, ONE). Its peak vPeak
// is the star's energy over 2 pi sigma^2, so its pixels sum to the energy wherever its centre lies
// within a pixel: as the camera turns, energy moves smoothly between pixels (no shimmer).
flat in vec2 vCentre;
flat in vec3 vPeak;
uniform float uInvTwoSigma2;
out vec4 fragColour;

void main() {
  vec2 d = gl_FragCoord.xy - vCentre;
  fragColour = vec4(vPeak * exp(-dot(d, d) * uInvTwoSigma2), 0.0);
}
