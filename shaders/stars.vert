// The stars (issue 23, planet/gl/src/StarsPass.hpp): each star a point at infinity, only its
// direction used (camera-relative by construction: no position, no precision issue). The J2000
// unit vector is turned into ECEF by uCelestialToWorld (astro::celestialToEcef at the scene's
// time), then projected with the rotation-only view-projection (w = 0: a direction) or, with
// TELLUS_FISHEYE and uFisheye = 1, through the direct dome's angular fisheye map exactly as
// shaders/planet.vert maps a vertex (uDomeRotation, uDomeMap set by Dome::beginDirect). Depth is
// put mid-range (z = w / 2): the depth test is off and neither the near nor the far plane may clip
// a star. The fragment shader draws a Gaussian footprint around the star's window position
// (vCentre, pixels), passed flat. The renderer prepends #version and the #defines.
layout(location = 0) in vec3 aDirection; // unit vector, J2000 celestial frame
layout(location = 1) in vec3 aPeak;      // linear RGB at the footprint's centre (colour x peak)

uniform mat3 uCelestialToWorld; // J2000 -> ECEF at the scene's time
uniform mat4 uViewProj;         // projection * view rotation (the eye at the origin)
uniform vec2 uViewport;         // the target's size in pixels
#ifdef TELLUS_FISHEYE
uniform int uFisheye;       // 1: the fisheye map below; 0: uViewProj (the cube faces)
uniform mat3 uDomeRotation; // world axes -> the dome's frame (x right, y up, the axis -z)
uniform vec4 uDomeMap;      // xy: NDC per radian along x and y; z: the clip angle; w: near
out float gl_ClipDistance[1];
#endif

flat out vec2 vCentre; // window pixels
flat out vec3 vPeak;

void main() {
  vec3 d = uCelestialToWorld * aDirection;
  vec4 clip = uViewProj * vec4(d, 0.0);
#ifdef TELLUS_FISHEYE
  gl_ClipDistance[0] = 1.0;
  if (uFisheye != 0) {
    vec3 q = uDomeRotation * d;
    float lateral = length(q.xy);
    float theta = atan(lateral, -q.z);
    float k = lateral > 1e-6 ? theta / lateral : 1.0;
    clip = vec4(q.xy * k * uDomeMap.xy, 0.0, 1.0);
    gl_ClipDistance[0] = uDomeMap.z - theta;
  }
#endif
  clip.z = 0.5 * clip.w;
  gl_Position = clip;
  vCentre = (clip.xy / clip.w * 0.5 + 0.5) * uViewport;
  vPeak = aPeak;
}
