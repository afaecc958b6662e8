// Node meshes, relative to the eye. Every vertex is its ECEF position (metres, double on the CPU);
// the eye's position is subtracted on the GPU before anything is narrowed to float, with one
// view-projection for every node (the rotation only, the eye at the origin). Two nodes holding the
// same point (a shared edge, a zero-area triangle's coarse vertex) therefore put it at
// bit-identical clip coordinates, which makes edges watertight.
//
// TELLUS_FP64 (OpenGL 4.x): the position is a dvec3 and the subtraction is one double operation.
// Otherwise (OpenGL 3.3) it arrives as two floats, high = float(x) and low = float(x - high), and
// (high - eyeHigh) + (low - eyeLow) is computed in float, in that order (`precise` where GLSL has
// it). The floats are packed on the CPU by planet/src/GpuVertex.cpp, which GCC 12 once miscompiled
// (the low floats zeroed: positions snapped to 0.5 m; docs/ACCURACY.md, finding 7). The renderer
// prepends #version and the #define.
#if __VERSION__ >= 400
#define PRECISE precise
#else
#define PRECISE
#endif
#ifdef TELLUS_FP64
layout(location = 0) in dvec3 aPosition;
uniform dvec3 uEye;
#else
layout(location = 0) in vec3 aHigh;
layout(location = 1) in vec3 aLow;
uniform vec3 uEyeHigh;
uniform vec3 uEyeLow;
#endif
layout(location = 2) in vec3 aNormal;
layout(location = 3) in vec2 aUvNode;
// Geomorphing (issue 23, planet/Morph.hpp): xyz the offset (m) to where the parent's coarser mesh
// puts this vertex, w that parent's north-south extent (m). uMorph.x: the scale of
// planet::morphScale (focal px / (threshold x tile px)); uMorph.y: 1 = morph, 0 = off. The
// factor f = clamp(2 d / (w x scale) - 1, 0, 1) of the vertex's distance d from the eye (the
// parent's position at the parent's split distance, its own at half of it), the same for every
// node holding the vertex (the same inputs, bit for bit), so edges stay watertight.
layout(location = 4) in vec4 aMorph;
uniform vec2 uMorph;

vec3 morphed(vec3 p) {
  if (uMorph.y < 0.5) return p;
  float range = aMorph.w * uMorph.x;
  float f = range > 0.0 ? clamp(2.0 * length(p) / range - 1.0, 0.0, 1.0) : 0.0;
  return p + f * aMorph.xyz;
}

uniform mat4 uViewProj; // projection * view rotation (the eye at the origin)
// uvTexture = uvNode * uUv.xy + uUv.zw (own texture, a child's or an ancestor's part, or global)
uniform vec4 uUv;
// TELLUS_FISHEYE (a renderer whose dome draws directly, issue #7): with uFisheye = 1 each vertex
// goes through the angular fisheye (azimuthal equidistant) map itself: q = p in the dome's frame
// (x right, y up, the axis along -z), theta = atan(|q.xy|, -q.z) (not acos: stable near 0 and
// pi), the image position theta / halfFov x q.xy / |q.xy| (its limit q.xy / |q| at the axis;
// nearly straight behind, where the direction is lost, it fades to the centre: clipped anyway),
// w = |q| (attributes interpolated perspective-correctly along the edge's angle), depth near / |q|
// (reversed Z as in the flat path), and gl_ClipDistance[0] = halfFov + margin - theta drops what
// lies behind. src/DomeDirect.cpp mirrors the map in double. uFisheye = 0: the perspective (the
// cube faces of the fallback).
#ifdef TELLUS_FISHEYE
uniform int uFisheye;       // 1: the fisheye map below; 0: uViewProj
uniform mat3 uDomeRotation; // world axes -> the dome's frame (x right, y up, axis -z)
uniform vec4 uDomeMap;      // xy: NDC per radian along x and y; z: the clip angle; w: near (m)
out float gl_ClipDistance[1];
#endif

out vec2 vUv;
out vec2 vUvNode; // the node's own coordinates (overlays have transforms of their own)
out vec3 vNormal;
// The ellipsoid's outward normal at the vertex (ECEF, not normalised): the "up" the sun's
// elevation is measured from (planet.frag), the same on a mountain as on the plain below it.
// uPolarScale = (a / b)^2 of the body (1 for a sphere): the gradient of x^2/a^2 + y^2/a^2 +
// z^2/b^2 is (x, y, z (a/b)^2) / a^2. From the float position: an Earth-sized coordinate to
// 0.5 m, a direction to 1e-7 radian.
out vec3 vUp;
uniform float uPolarScale;
// Later passes (overlays past the texture units) draw the same mesh with depth test EQUAL-or-
// nearer: the position must come out bit for bit the same in every pass.
invariant gl_Position;

void main() {
  vUv = aUvNode * uUv.xy + uUv.zw;
  vUvNode = aUvNode;
  vNormal = aNormal;
#ifdef TELLUS_FP64
  vec3 world = vec3(aPosition);
#else
  vec3 world = aHigh;
#endif
  vUp = vec3(world.xy, world.z * uPolarScale);
#ifdef TELLUS_FP64
  vec3 p = morphed(vec3(aPosition - uEye));
#else
  PRECISE vec3 highDiff = aHigh - uEyeHigh;
  PRECISE vec3 lowDiff = aLow - uEyeLow;
  PRECISE vec3 pOwn = highDiff + lowDiff;
  vec3 p = morphed(pOwn);
#endif
#ifdef TELLUS_FISHEYE
  if (uFisheye != 0) {
    vec3 q = uDomeRotation * p;
    float lateral = length(q.xy);
    float dist = max(length(q), 1e-20);
    float theta = atan(lateral, -q.z);
    float k = lateral > 1e-6 * dist ? theta / lateral
              : q.z < 0.0           ? 1.0 / dist
                                    : theta / (1e-6 * dist);
    gl_Position = vec4(q.xy * (k * dist) * uDomeMap.xy, uDomeMap.w, dist);
    gl_ClipDistance[0] = uDomeMap.z - theta;
    return;
  }
  gl_ClipDistance[0] = 1.0;
#endif
  gl_Position = uViewProj * vec4(p, 1.0);
}
