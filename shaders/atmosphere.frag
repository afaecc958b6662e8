// The atmosphere pass (issue 23; planet/gl/src/AtmospherePass.cpp): the sky where the globe drew
// nothing (depth 0), aerial perspective over what it drew (the distance from the depth it wrote),
// from Bruneton's (2017) precomputed tables (planet/include/tellus/planet/Atmosphere.hpp), with
// Hillaire's (2020) multiple scattering folded into them. The geometry and texture maps are
// planet/src/AtmosphereGeometry.hpp's, line for line, in float; AtmosphereTables::ray() is the
// CPU mirror of atmosphereRay() below. Keep all three in step.
//
// Camera-relative: the eye's altitude and up direction come from the CPU (double there); per
// pixel only a unit direction is in float. Everything is done in the "sphere space" of an
// ellipsoidal body: the polar axis stretched by uScale.z = equatorial / polar radius.
//
// Output by dual-source blending (GL 3.3, glBlendFunc(GL_ONE, GL_SRC1_COLOR)): the framebuffer
// becomes colour + what was there x factor, with colour the inscatter's display value and factor
// the transmittance's, so the terrain's colour is dimmed and hazed by the air in front of it.
in vec2 vNdc;
layout(location = 0, index = 0) out vec4 outColor;
layout(location = 0, index = 1) out vec4 outFactor;

uniform sampler2D uTransmittance;
uniform sampler3D uScattering; // Rayleigh + multiple (divided by the Rayleigh phase)
uniform sampler3D uMie;
uniform sampler2D uDepth; // the globe's depth (reversed Z: near / distance; 0: nothing)

uniform mat4 uInvViewProj; // flat: clip -> world direction (the eye at the origin)
uniform int uFisheye;      // 1: the direct dome's fisheye
uniform mat3 uDomeToWorld; // fisheye: the dome's frame (x right, y up, axis -z) -> world
uniform vec3 uFisheyeMap;  // xy: NDC per radian; z: the half angle (radians)
uniform vec3 uForward;     // flat: the view axis (distance = near / depth / cos)
uniform float uNear;       // metres
uniform int uClipControl;  // 0: depth = (near / w + 1) / 2

uniform vec3 uScale; // world -> sphere space
uniform vec3 uUp;    // the eye's zenith in sphere space
uniform float uEyeAltitude; // metres above the bottom (may exceed the top)
uniform vec3 uSun;          // unit, sphere space

uniform vec4 uShell;      // bottom radius, top radius, top altitude, H
uniform vec4 uSizes;      // scattering nu, mu_s, mu, r sizes
uniform vec4 uTexSizes;   // transmittance w, h; muSMin; Mie g
uniform vec4 uSunDisc;    // cos(angular radius), radiance scale (1 / (pi alpha^2)), exposure, -
uniform vec3 uSolar;      // the solar irradiance

const float kPi = 3.14159265358979;

float bottomR() { return uShell.x; }
float topR() { return uShell.y; }
float topAlt() { return uShell.z; }
float bigH() { return uShell.w; }

float clampCos(float mu) { return clamp(mu, -1.0, 1.0); }
float rhoOf(float h) { return sqrt(max(0.0, h * (2.0 * bottomR() + h))); }
float unitToCoord(float x, float n) { return 0.5 / n + x * (1.0 - 1.0 / n); }

float distanceToTop(float h, float mu) {
  float r = bottomR() + h;
  float c = (topAlt() - h) * (topR() + r);
  float disc = r * r * mu * mu + c;
  if (disc < 0.0) return 0.0;
  float q = sqrt(disc);
  if (mu <= 0.0) return max(0.0, q - r * mu);
  float den = q + r * mu;
  return den > 0.0 ? max(0.0, c / den) : 0.0;
}
bool hitsGround(float h, float mu) {
  float r = bottomR() + h;
  return mu < 0.0 && r * r * mu * mu - h * (2.0 * bottomR() + h) >= 0.0;
}
float distanceToBottom(float h, float mu) {
  float r = bottomR() + h;
  float c = h * (2.0 * bottomR() + h);
  float q = sqrt(max(0.0, r * r * mu * mu - c));
  float den = q - r * mu;
  return den > 0.0 ? max(0.0, c / den) : 0.0;
}

vec3 transmittanceToTop(float h, float mu) {
  float rho = rhoOf(h);
  float d = distanceToTop(h, mu);
  float dMin = topAlt() - h, dMax = rho + bigH();
  float xMu = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
  vec2 uv = vec2(unitToCoord(clamp(xMu, 0.0, 1.0), uTexSizes.x),
                 unitToCoord(clamp(rho / bigH(), 0.0, 1.0), uTexSizes.y));
  return texture(uTransmittance, uv).rgb;
}

float muSToUnit(float muS) {
  float dMin = topAlt(), dMax = bigH();
  float d = distanceToTop(0.0, muS);
  float a = (d - dMin) / (dMax - dMin);
  float A = (distanceToTop(0.0, uTexSizes.z) - dMin) / (dMax - dMin);
  return max(1.0 - a / A, 0.0) / (1.0 + a);
}

void lookupScattering(float h, float mu, float muS, float nu, bool ground, out vec3 rayleigh,
                      out vec3 mie) {
  float rho = rhoOf(h);
  float ur = unitToCoord(clamp(rho / bigH(), 0.0, 1.0), uSizes.w);
  float half_ = uSizes.z * 0.5;
  float umu;
  if (ground) {
    float d = distanceToBottom(h, mu);
    float dMin = h, dMax = rho;
    float x = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
    umu = 0.5 - 0.5 * unitToCoord(clamp(x, 0.0, 1.0), half_);
  } else {
    float d = distanceToTop(h, mu);
    float dMin = topAlt() - h, dMax = rho + bigH();
    float x = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
    umu = 0.5 + 0.5 * unitToCoord(clamp(x, 0.0, 1.0), half_);
  }
  float umus = unitToCoord(clamp(muSToUnit(muS), 0.0, 1.0), uSizes.y);
  float x = clamp((nu + 1.0) / 2.0, 0.0, 1.0) * (uSizes.x - 1.0);
  float slice = min(floor(x), uSizes.x - 2.0);
  float f = x - slice;
  vec3 uvw0 = vec3((slice + umus) / uSizes.x, umu, ur);
  vec3 uvw1 = vec3((slice + 1.0 + umus) / uSizes.x, umu, ur);
  rayleigh = mix(texture(uScattering, uvw0).rgb, texture(uScattering, uvw1).rgb, f);
  mie = mix(texture(uMie, uvw0).rgb, texture(uMie, uvw1).rgb, f);
}

float rayleighPhase(float nu) { return 3.0 / (16.0 * kPi) * (1.0 + nu * nu); }
float miePhase(float g, float nu) {
  float k = 3.0 / (8.0 * kPi) * (1.0 - g * g) / (2.0 + g * g);
  return k * (1.0 + nu * nu) / pow(max(1e-6, 1.0 + g * g - 2.0 * g * nu), 1.5);
}

// The sky along a ray (AtmosphereTables::ray): sin2 = |dir x up|^2 (precise where mu is near -1,
// far from the body), distance < 0: the sky (no surface).
void atmosphereRay(float h, float mu, float sin2, float muS, float nu, float distance,
                   out vec3 inscatter, out vec3 transmittance, out bool seesSpace) {
  inscatter = vec3(0.0);
  transmittance = vec3(1.0);
  seesSpace = true;
  h = max(h, 0.0);
  mu = clampCos(mu);
  if (h > topAlt()) {
    float r = bottomR() + h;
    float p2 = r * r * sin2;
    if (mu >= 0.0 || p2 >= topR() * topR()) return;
    float q = sqrt(topR() * topR() - p2);
    float entry = -r * mu - q;
    muS = clampCos((r * muS + entry * nu) / topR());
    mu = -q / topR();
    h = topAlt();
    if (distance >= 0.0) {
      distance -= entry;
      if (distance <= 0.0) return;
    }
  }
  bool ground = hitsGround(h, mu);
  seesSpace = !ground;
  float pr = rayleighPhase(nu), pm = miePhase(uTexSizes.w, nu);
  vec3 rayleigh, mie;
  lookupScattering(h, mu, muS, nu, ground, rayleigh, mie);
  if (distance >= 0.0) {
    float r = bottomR() + h;
    float e = max(0.0, distance * distance + 2.0 * r * mu * distance + h * (2.0 * bottomR() + h));
    float rd = sqrt(e + bottomR() * bottomR());
    float hd = e / (rd + bottomR());
    float mud = clampCos((r * mu + distance) / rd);
    float muSd = clampCos((r * muS + distance * nu) / rd);
    if (ground)
      transmittance = min(vec3(1.0), transmittanceToTop(hd, -mud) /
                                         max(transmittanceToTop(h, -mu), vec3(1e-30)));
    else
      transmittance = min(vec3(1.0), transmittanceToTop(h, mu) /
                                         max(transmittanceToTop(hd, mud), vec3(1e-30)));
    vec3 farR, farM;
    lookupScattering(hd, mud, muSd, nu, ground, farR, farM);
    rayleigh = max(vec3(0.0), rayleigh - transmittance * farR);
    mie = max(vec3(0.0), mie - transmittance * farM);
    mie *= smoothstep(0.0, 0.01, muS);
    seesSpace = false;
  } else {
    transmittance = ground ? vec3(0.0) : transmittanceToTop(h, mu);
  }
  inscatter = rayleigh * pr + mie * pm;
}

// The pixel's world direction, or false outside the fisheye's circle.
bool pixelDirection(out vec3 dir) {
  if (uFisheye != 0) {
    vec2 v = vNdc / uFisheyeMap.xy; // radians, along the image's x and y
    float theta = length(v);
    if (theta > uFisheyeMap.z + 0.05) return false;
    vec2 side = theta > 0.0 ? v / theta : vec2(0.0);
    vec3 q = vec3(side * sin(theta), -cos(theta));
    dir = normalize(uDomeToWorld * q);
    return true;
  }
  vec4 p = uInvViewProj * vec4(vNdc, 1.0, 1.0);
  dir = normalize(p.xyz / p.w);
  return true;
}

void main() {
  vec3 dir;
  if (!pixelDirection(dir)) {
    outColor = vec4(0.0);
    outFactor = vec4(1.0);
    return;
  }
  float depth = texelFetch(uDepth, ivec2(gl_FragCoord.xy), 0).r;
  float distance = -1.0;
  if (depth > 0.0) {
    float nd = uClipControl != 0 ? depth : 2.0 * depth - 1.0;
    float along = uNear / max(nd, 1e-30); // along the view axis (flat) or the ray (fisheye)
    distance = uFisheye != 0 ? along : along / max(dot(dir, uForward), 1e-6);
  }
  vec3 sdir = uScale * dir;
  float stretch = length(sdir);
  sdir /= stretch;
  if (distance >= 0.0) distance *= stretch;
  vec3 c = cross(sdir, uUp);
  float mu = dot(sdir, uUp);
  float muS = dot(uUp, uSun);
  float nu = dot(sdir, uSun);
  vec3 inscatter, transmittance;
  bool seesSpace;
  atmosphereRay(uEyeAltitude, mu, dot(c, c), muS, nu, distance, inscatter, transmittance,
                seesSpace);
  // The sun's disc, where the ray reaches space, dimmed by the air.
  if (distance < 0.0 && seesSpace && nu > uSunDisc.x)
    inscatter += transmittance * uSolar * uSunDisc.y;
  // Display: 1 - exp(-exposure L) (a soft shoulder), then gamma 2.2; the terrain behind is
  // already display-encoded, so its factor is the transmittance's gamma-encoded value, leaving
  // room for the inscatter (a screen blend: the sum never exceeds 1).
  vec3 glow = pow(vec3(1.0) - exp(-uSunDisc.z * inscatter), vec3(1.0 / 2.2));
  outColor = vec4(glow, 0.0);
  outFactor = vec4(pow(transmittance, vec3(1.0 / 2.2)) * (vec3(1.0) - glow), 1.0);
}
