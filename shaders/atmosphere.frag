// The atmosphere pass (issue 23; planet/gl/src/AtmospherePass.cpp): the sky where the globe drew
// nothing (depth 0), aerial perspective over what it drew (the distance from the depth it wrote),
// read from the view tables shaders/atmosphere_lut.frag filled for this eye and sun (Hillaire
// 2020's sky-view and aerial-perspective tables, made here from Bruneton's 2017 precomputed
// tables): per pixel the direction's azimuth and zenith coordinates, for the haze the distance's
// slice, three lookups, the phase functions with the exact nu. Prepended by
// shaders/atmosphere_common.glsl.
//
// Output by dual-source blending (GL 3.3, glBlendFunc(GL_ONE, GL_SRC1_COLOR)): the framebuffer
// becomes colour + what was there x factor, with colour the inscatter's display value and factor
// the transmittance's, so the terrain's colour is dimmed and hazed by the air in front of it.
in vec2 vNdc;
in vec4 vRay; // flat: the inverse view-projection of the pixel (shaders/atmosphere.vert)
layout(location = 0, index = 0) out vec4 outColor;
layout(location = 0, index = 1) out vec4 outFactor;

uniform sampler2D uSkyRayleigh; // the sky table: azimuth x zenith (AtmospherePass.hpp)
uniform sampler2D uSkyMie;
uniform sampler2D uSkyTransmittance;
uniform sampler3D uAirRayleigh; // the aerial table: azimuth x zenith x distance
uniform sampler3D uAirMie;
uniform sampler3D uAirTransmittance;
uniform sampler2D uDepth; // the globe's depth (reversed Z: near / distance; 0: nothing)

uniform int uFisheye;      // 1: the direct dome's fisheye
uniform mat3 uDomeToWorld; // fisheye: the dome's frame (x right, y up, axis -z) -> world
uniform vec3 uFisheyeMap;  // xy: NDC per radian; z: the half angle (radians)
uniform vec3 uForward;     // flat: the view axis (distance = near / depth / cos)
uniform float uNear;       // metres
uniform int uClipControl;  // 0: depth = (near / w + 1) / 2

uniform vec3 uScale;   // world -> sphere space
uniform vec3 uUp;      // the eye's zenith in sphere space
uniform vec3 uSun;     // unit, sphere space
uniform vec3 uSunSide; // the sun's horizontal direction at the eye (any when it is at the zenith)
uniform vec3 uSunNormal; // uUp x uSunSide
uniform vec2 uSkyLut;    // the sky table's azimuth, zenith sizes
uniform vec4 uEye;    // the eye: r, r^2 - bottom^2, top^2 - r^2 (m^2), 1 inside the shell, 0 above
uniform vec4 uZenith; // Bruneton's zenith map at the eye: ground dMin, 1 / (dMax - dMin); sky same
uniform vec4 uSunDisc;   // cos(angular radius), radiance scale (1 / (pi alpha^2)), exposure, -
uniform vec3 uSolar;     // the solar irradiance

// The view ray's zenith coordinate x in [0, 1] within its half (ground: it reaches the bottom),
// where it enters the shell (t0, 0 from inside) and leaves it (t1); false: it misses the shell.
// The same values as viewSpan() and zenithUnit() (shaders/atmosphere_common.glsl), from the
// eye's constants of uEye and uZenith (AtmospherePass::setUniforms): two square roots a pixel.
bool zenithOf(vec3 sdir, out float x, out bool ground, out float t0, out float t1) {
  float mu = dot(sdir, uUp);
  float r = uEye.x;
  t0 = 0.0;
  if (uEye.w > 0.5) { // the eye inside the shell
    float rmu = r * mu;
    float disc = rmu * rmu - uEye.y;
    ground = mu < 0.0 && disc >= 0.0;
    if (ground) {
      t1 = uEye.y / max(sqrt(max(disc, 0.0)) - rmu, 1e-30);
      x = (t1 - uZenith.x) * uZenith.y;
    } else {
      float q = sqrt(rmu * rmu + uEye.z);
      t1 = mu <= 0.0 ? q - rmu : uEye.z / (q + rmu);
      x = (t1 - uZenith.z) * uZenith.w;
    }
  } else { // above it: where the ray enters the top
    vec3 c = cross(sdir, uUp);
    float q2 = topR() * topR() - r * r * dot(c, c);
    ground = false;
    t1 = 0.0;
    x = 0.0;
    if (mu >= 0.0 || q2 <= 0.0) return false;
    float q = sqrt(q2);
    t0 = -r * mu - q;
    float g2 = q2 - bigH() * bigH(); // >= 0: the ray reaches the bottom
    ground = g2 >= 0.0;
    if (ground) {
      float d = q - sqrt(g2);
      t1 = t0 + d;
      x = (d - topAlt()) / (bigH() - topAlt());
    } else {
      t1 = t0 + 2.0 * q;
      x = q / bigH();
    }
  }
  x = clamp(x, 0.0, 1.0);
  return true;
}

void main() {
  // The pixel's ray, not normalised: flat, interpolated from the vertices (the inverse
  // view-projection is affine in NDC); the fisheye's per pixel.
  vec3 ray;
  if (uFisheye != 0) {
    vec2 v = vNdc / uFisheyeMap.xy; // radians, along the image's x and y
    float theta = length(v);
    if (theta > uFisheyeMap.z + 0.05) {
      outColor = vec4(0.0);
      outFactor = vec4(1.0);
      return;
    }
    vec2 side = theta > 0.0 ? v / theta : vec2(0.0);
    ray = normalize(uDomeToWorld * vec3(side * sin(theta), -cos(theta)));
  } else {
    ray = vRay.xyz * sign(vRay.w);
  }
  float depth = texelFetch(uDepth, ivec2(gl_FragCoord.xy), 0).r;
  // Into sphere space; the distance from the depth (near / depth along the view axis, flat, or
  // along the ray, fisheye) stretched with it: |S ray| / (ray . forward) per unit of the axis.
  vec3 sray = uScale * ray;
  float slen = length(sray);
  vec3 sdir = sray / slen;
  float distance = -1.0;
  if (depth > 0.0) {
    float nd = uClipControl != 0 ? depth : 2.0 * depth - 1.0;
    float along = uNear / max(nd, 1e-30);
    distance = uFisheye != 0 ? along * slen : along * slen / max(dot(ray, uForward), 1e-30);
  }
  float nu = dot(sdir, uSun);
  vec3 rayleigh = vec3(0.0), mie = vec3(0.0), transmittance = vec3(1.0);
  bool seesSpace = distance < 0.0;
  float x, t0, t1;
  bool ground;
  if (zenithOf(sdir, x, ground, t0, t1)) {
    // The azimuth from the sun's: u = sin(phi / 2) (the tables' phi = 2 asin(u)).
    float ax = dot(sdir, uSunSide), ay = dot(sdir, uSunNormal);
    float az = sqrt(max(0.0, 0.5 - 0.5 * ax * inversesqrt(max(ax * ax + ay * ay, 1e-30))));
    if (distance < 0.0) {
      vec2 uv = vec2(unitToCoord(az, uSkyLut.x), zenithCoord(x, ground, uSkyLut.y));
      rayleigh = texture(uSkyRayleigh, uv).rgb;
      mie = texture(uSkyMie, uv).rgb;
      transmittance = ground ? vec3(0.0) : texture(uSkyTransmittance, uv).rgb;
      seesSpace = !ground;
    } else {
      vec3 uvw = vec3(unitToCoord(az, uAirLut.x), zenithCoord(x, ground, uAirLut.y),
                      unitToCoord(sliceUnit(distance, t0, t1), uAirLut.z));
      rayleigh = texture(uAirRayleigh, uvw).rgb;
      mie = texture(uAirMie, uvw).rgb;
      transmittance = texture(uAirTransmittance, uvw).rgb;
    }
  }
  vec3 inscatter = rayleigh * rayleighPhase(nu) + mie * miePhase(uTexSizes.w, nu);
  // The sun's disc, where the ray reaches space, dimmed by the air.
  if (seesSpace && nu > uSunDisc.x) inscatter += transmittance * uSolar * uSunDisc.y;
  // Display: 1 - exp(-exposure L) (a soft shoulder), then gamma 2.2; the terrain behind is
  // already display-encoded, so its factor is the transmittance's gamma-encoded value, leaving
  // room for the inscatter (a screen blend: the sum never exceeds 1).
  vec3 glow = pow(vec3(1.0) - exp(-uSunDisc.z * inscatter), vec3(1.0 / 2.2));
  outColor = vec4(glow, 0.0);
  outFactor = vec4(pow(transmittance, vec3(1.0 / 2.2)) * (vec3(1.0) - glow), 1.0);
}
