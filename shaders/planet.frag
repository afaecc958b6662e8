// The node's texture (or its fallback) through the uv transform; with a sun (uSun.w = 1), diffuse
// lighting from the terrain's normals in world space (ECEF), with some ambient light.
in vec2 vUv;
in vec3 vNormal;

uniform sampler2D uTexture;
uniform vec4 uSun; // xyz: unit direction to the sun (ECEF); w: 1 = lit, 0 = unlit

out vec4 fragColor;

void main() {
  vec3 colour = texture(uTexture, vUv).rgb;
  if (uSun.w > 0.5) {
    float diffuse = max(dot(normalize(vNormal), uSun.xyz), 0.0);
    colour *= 0.25 + 0.75 * diffuse;
  }
  fragColor = vec4(colour, 1.0);
}
