// Another body of the scene drawn whole as a coarse globe (issue 26; planet/gl/src/BodiesPass.hpp,
// planet/SceneBodies.hpp). Positions arrive camera-relative: the CPU subtracted the eye in double
// (the body's centre minus the eye, plus the rotated body-fixed offset) and only then narrowed to
// float, so the float holds no Earth-Moon distance's bits beyond its relative precision (~50 m at
// 400,000 km: far under a pixel). With TELLUS_FISHEYE and uFisheye = 1 each vertex goes through
// the direct dome's fisheye map exactly as shaders/planet.vert maps it. The renderer prepends
// #version and the #defines.
layout(location = 0) in vec3 aPosition; // relative to the eye, the scene's frame, metres
layout(location = 1) in vec3 aNormal;   // the ellipsoid's unit normal, the scene's frame
layout(location = 2) in vec2 aUv;       // the equirectangular global image's

uniform mat4 uViewProj; // projection * view rotation (the eye at the origin)
#ifdef TELLUS_FISHEYE
uniform int uFisheye;       // 1: the fisheye map below; 0: uViewProj (the cube faces)
uniform mat3 uDomeRotation; // world axes -> the dome's frame (x right, y up, the axis -z)
uniform vec4 uDomeMap;      // xy: NDC per radian along x and y; z: the clip angle; w: near (m)
out float gl_ClipDistance[1];
#endif

out vec3 vNormal;
out vec2 vUv;

void main() {
  vNormal = aNormal;
  vUv = aUv;
  vec3 p = aPosition;
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
