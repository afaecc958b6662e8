// The node's texture (or its fallback) through the uv transform, then the overlay layers over it
// in order (issue #7); with a sun (uSun.w = 1), sunlight and the night side (issue 23).
//
// Textures hold premultiplied alpha (the decoder premultiplies), so each overlay composites as
// colour = colour * (1 - a) + rgb, with its opacity scaling all four channels. A first pass
// (uBase = 1) starts from the opaque base texture and writes alpha 1; a later pass (uBase = 0)
// composites further overlays onto transparent black and is blended onto the first pass's result
// with (ONE, ONE_MINUS_SRC_ALPHA), which gives the same colour as one pass would (lighting is a
// factor on colour, so it distributes over the blend). The renderer prepends #version and the
// defines TELLUS_OVERLAYS (texture units for overlays, >= 1) and TELLUS_OVERLAY_STEPS (one
// TELLUS_OVERLAY(i) per unit: sampler arrays take constant indices only in GLSL 3.30).
//
// Sunlight: the sun's elevation at the point is measured from the ellipsoid's normal (vUp):
// sinElev = dot(up, sun). The surface takes kAmbient (light from the sky and the Earth's
// neighbourhood: the night side is dark, the continents still faintly there) plus diffuse light
// from the relief's own normal (vNormal: a slope facing the sun is brighter than the plain),
// times `day`, a smoothstep of sinElev over +-0.05 (+-2.9 degrees: the sun's disc, refraction and
// twilight soften the terminator; a peak beyond it catches light a little longer than the plain).
//
// Night layers (uOverlayNight[i] = 1, RendererOptions' LayerOptions::night): light, not a
// surface: added after the lighting with the weight 1 - smoothstep(-0.105, 0, sinElev) (none
// while the sun is up, full from civil dusk, the sun 6 degrees below the horizon, on). Their alpha
// covers nothing; the surface overlays drawn after one cover its light by their own alpha. A
// later pass writes its light with alpha 0, which (ONE, ONE_MINUS_SRC_ALPHA) adds. Unlit (uSun.w
// = 0): night layers show nothing.
//
// Layers of values (issue 24; uOverlayValues[i].x = 1): the overlay's texture holds one float a
// texel (R32F, NaN = no data, rows from the south), never filtered by GL: valueAt reads the four
// texels around the point with texelFetch and follows values/Sample.hpp's rule (the one the
// proxy's composed maps and values::sample follow) in float: texel centres at +0.5, clamped to
// the texture's edges; bilinear of the values; where one of the four is NaN, the texel the point
// lies in (ties to the second texel, counted as the CPU counts them: rows from the north). The
// value is then coloured by values/ColourScale.hpp's rule in float: t = (v - low) / (high - low)
// (log: of log10 v, low and high already log10; v <= 0 below the range), out of the range
// transparent (uOverlayValues[i].w = 1) or clamped, index = clamp(floor(t * 256), 0, 255) into
// row uOverlayValues[i].y of uColourMaps (one 256-entry map a row), opaque; no data transparent.
in vec2 vUv;
in vec2 vUvNode;
in vec3 vNormal;
in vec3 vUp;

uniform sampler2D uTexture;
uniform vec4 uSun;   // xyz: unit direction to the sun (ECEF); w: 1 = lit, 0 = unlit
uniform float uBase; // 1: the base texture under the overlays; 0: overlays only (a later pass)
uniform int uOverlayCount;
uniform sampler2D uOverlay[TELLUS_OVERLAYS];
uniform vec4 uOverlayUv[TELLUS_OVERLAYS]; // uvOverlay = uvNode * xy + zw
uniform float uOverlayOpacity[TELLUS_OVERLAYS];
uniform float uOverlayNight[TELLUS_OVERLAYS]; // 1: a night layer (light on the dark side)
uniform vec4 uOverlayValues[TELLUS_OVERLAYS]; // x: 1 = values; y: map row; z: 1 = log; w: 1 = cut
uniform vec2 uOverlayRange[TELLUS_OVERLAYS];  // the range's low and high (log: their log10)
uniform sampler2D uColourMaps;

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

const float kAmbient = 0.04;

// values::axisTexels and values::bilinearValue (values/Sample.hpp) in float. p: texel
// coordinates with y counted from the north edge (the CPU's rows).
float valueAt(sampler2D values, vec2 uv) {
  ivec2 size = textureSize(values, 0);
  vec2 p = vec2(uv.x, 1.0 - uv.y) * vec2(size);
  vec2 g = clamp(p - 0.5, vec2(0.0), vec2(size - 1));
  ivec2 i0 = ivec2(floor(g));
  ivec2 i1 = min(i0 + 1, size - 1);
  vec2 f = g - vec2(i0);
  // Rows from the north -> the texture's rows (from the south).
  int r0 = size.y - 1 - i0.y, r1 = size.y - 1 - i1.y;
  float v00 = texelFetch(values, ivec2(i0.x, r0), 0).r;
  float v10 = texelFetch(values, ivec2(i1.x, r0), 0).r;
  float v01 = texelFetch(values, ivec2(i0.x, r1), 0).r;
  float v11 = texelFetch(values, ivec2(i1.x, r1), 0).r;
  if (isnan(v00) || isnan(v10) || isnan(v01) || isnan(v11)) {
    bool right = f.x >= 0.5, down = f.y >= 0.5;
    return down ? (right ? v11 : v01) : (right ? v10 : v00);
  }
  float top = v00 * (1.0 - f.x) + v10 * f.x;
  float bottom = v01 * (1.0 - f.x) + v11 * f.x;
  return top * (1.0 - f.y) + bottom * f.y;
}

vec4 valueColour(sampler2D values, vec2 uv, vec4 scale, vec2 range) {
  float v = valueAt(values, uv);
  if (isnan(v)) return vec4(0.0);
  float t;
  if (scale.z > 0.5 && v <= 0.0) t = -1.0;
  else {
    float x = scale.z > 0.5 ? log2(v) * 0.30102999566398120 : v;
    t = range.y > range.x ? (x - range.x) / (range.y - range.x) : (x < range.x ? -1.0 : x > range.x ? 2.0 : 0.5);
  }
  if ((t < 0.0 || t > 1.0) && scale.w > 0.5) return vec4(0.0);
  int index = int(clamp(floor(t * 256.0), 0.0, 255.0));
  return vec4(texelFetch(uColourMaps, ivec2(index, int(scale.y)), 0).rgb, 1.0);
}

vec4 overlayTexel(sampler2D s, int i) {
  vec2 uv = vUvNode * uOverlayUv[i].xy + uOverlayUv[i].zw;
  return uOverlayValues[i].x > 0.5 ? valueColour(s, uv, uOverlayValues[i], uOverlayRange[i]) : texture(s, uv);
}

#define TELLUS_OVERLAY(i) if (uOverlayCount > i) { vec4 o = overlayTexel(uOverlay[i], i) * uOverlayOpacity[i]; if (uOverlayNight[i] > 0.5) { light += o.rgb * night; } else { colour = colour * (1.0 - o.a) + o.rgb; alpha = alpha * (1.0 - o.a) + o.a; light *= 1.0 - o.a; } }

void main() {
  vec3 colour = vec3(0.0);
  float alpha = 0.0;
  vec3 light = vec3(0.0); // emitted: the night layers' light, not lit by the sun
  float sinElev = 1.0;
  if (uSun.w > 0.5) sinElev = dot(normalize(vUp), uSun.xyz);
  float night = uSun.w > 0.5 ? 1.0 - smoothstep(-0.105, 0.0, sinElev) : 0.0;
  if (uBase > 0.5) {
    colour = fadeIn(texture(uTexture, vUv).rgb);
    alpha = 1.0;
  }
  TELLUS_OVERLAY_STEPS
  if (uSun.w > 0.5) {
    float diffuse = max(dot(normalize(vNormal), uSun.xyz), 0.0);
    float day = smoothstep(-0.05, 0.05, sinElev);
    colour *= kAmbient + (1.0 - kAmbient) * diffuse * day;
  }
  fragColor = vec4(colour + light, alpha);
}
