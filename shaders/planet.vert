// Node meshes, relative to the eye on the GPU: every vertex is its ECEF position (metres, double
// on the CPU) split into a high and a low float; the eye's position is split the same way, and
// (high - eyeHigh) + (lowDiff) gives the eye-relative position with about 1e-8 of a metre's error
// near the eye, without a per-node matrix. Two nodes holding the same point (a shared edge, a
// zero-area triangle's coarse vertex) therefore put it at bit-identical clip coordinates, so edges
// are watertight. The #version line is prepended by the renderer (450 core or 330 core).
#if __VERSION__ >= 400
#define PRECISE precise
#else
#define PRECISE
#endif
layout(location = 0) in vec3 aHigh;
layout(location = 1) in vec3 aLow;
layout(location = 2) in vec3 aNormal;
layout(location = 3) in vec2 aUvNode;

uniform mat4 uViewProj; // projection * view rotation (the eye at the origin)
uniform vec3 uEyeHigh;
uniform vec3 uEyeLow;
// uvTexture = uvNode * uUv.xy + uUv.zw (own texture, a child's or an ancestor's part, or global)
uniform vec4 uUv;

out vec2 vUv;
out vec3 vNormal;

void main() {
  vUv = aUvNode * uUv.xy + uUv.zw;
  vNormal = aNormal;
  PRECISE vec3 highDiff = aHigh - uEyeHigh;
  PRECISE vec3 lowDiff = aLow - uEyeLow;
  PRECISE vec3 p = highDiff + lowDiff;
  gl_Position = uViewProj * vec4(p, 1.0);
}
