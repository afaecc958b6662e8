// Another body of the scene (issue 26; planet/gl/src/BodiesPass.hpp): its global image (or flat
// colour), lit by the scene's sun as shaders/planet.frag lights the orbited body's bare
// ellipsoid: kAmbient plus the diffuse light of the normal, times a soft terminator over +-0.05
// of the sun's elevation. Unlit (uSun.w = 0): the image's own colours.
in vec3 vNormal;
in vec2 vUv;

uniform sampler2D uTexture;
uniform vec4 uSun; // xyz: unit direction to the sun (the scene's frame); w: 1 = lit, 0 = unlit

out vec4 fragColor;

const float kAmbient = 0.04; // as planet.frag's

void main() {
  vec3 colour = texture(uTexture, vUv).rgb;
  if (uSun.w > 0.5) {
    float sinElev = dot(normalize(vNormal), uSun.xyz);
    float day = smoothstep(-0.05, 0.05, sinElev);
    colour *= kAmbient + (1.0 - kAmbient) * max(sinElev, 0.0) * day;
  }
  fragColor = vec4(colour, 1.0);
}
