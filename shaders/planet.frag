// The node's texture (or its fallback) through the uv transform, then the overlay layers over it
// in order (issue #7); with a sun (uSun.w = 1), diffuse lighting from the terrain's normals in
// world space (ECEF), with some ambient light.
//
// Textures hold premultiplied alpha (the decoder premultiplies), so each overlay composites as
// colour = colour * (1 - a) + rgb, with its opacity scaling all four channels. A first pass
// (uBase = 1) starts from the opaque base texture and writes alpha 1; a later pass (uBase = 0)
// composites further overlays onto transparent black and is blended onto the first pass's result
// with (ONE, ONE_MINUS_SRC_ALPHA), which gives the same colour as one pass would (lighting is a
// factor on colour, so it distributes over the blend). The renderer prepends #version and the
// defines TELLUS_OVERLAYS (texture units for overlays, >= 1) and TELLUS_OVERLAY_STEPS (one
// TELLUS_OVERLAY(i) per unit: sampler arrays take constant indices only in GLSL 3.30).
in vec2 vUv;
in vec2 vUvNode;
in vec3 vNormal;

uniform sampler2D uTexture;
uniform vec4 uSun;   // xyz: unit direction to the sun (ECEF); w: 1 = lit, 0 = unlit
uniform float uBase; // 1: the base texture under the overlays; 0: overlays only (a later pass)
uniform int uOverlayCount;
uniform sampler2D uOverlay[TELLUS_OVERLAYS];
uniform vec4 uOverlayUv[TELLUS_OVERLAYS]; // uvOverlay = uvNode * xy + zw
uniform float uOverlayOpacity[TELLUS_OVERLAYS];

out vec4 fragColor;

// Fade-in (issue 23, no popping; DrawList.hpp planDraw): a texture that arrived less than the
// fade time ago is mixed over what the part showed before it (an ancestor's texture or the global
// one, through its own transform of the node's coordinates) by uFade in [0, 1]; uFade = 1 returns
// the colour unchanged (no mix: a settled frame is bit for bit what it is without fading).
uniform sampler2D uFadeFrom;
uniform vec4 uFadeUv; // uvFadeFrom = uvNode * xy + zw
uniform float uFade;

vec3 fadeIn(vec3 colour) {
  if (uFade >= 1.0) return colour;
  return mix(texture(uFadeFrom, vUvNode * uFadeUv.xy + uFadeUv.zw).rgb, colour, uFade);
}

#define TELLUS_OVERLAY(i) if (uOverlayCount > i) { vec4 o = texture(uOverlay[i], vUvNode * uOverlayUv[i].xy + uOverlayUv[i].zw) * uOverlayOpacity[i]; colour = colour * (1.0 - o.a) + o.rgb; alpha = alpha * (1.0 - o.a) + o.a; }

void main() {
  vec3 colour = vec3(0.0);
  float alpha = 0.0;
  if (uBase > 0.5) {
    colour = fadeIn(texture(uTexture, vUv).rgb);
    alpha = 1.0;
  }
  TELLUS_OVERLAY_STEPS
  if (uSun.w > 0.5) {
    float diffuse = max(dot(normalize(vNormal), uSun.xyz), 0.0);
    colour *= 0.25 + 0.75 * diffuse;
  }
  fragColor = vec4(colour, alpha);
}
