// The atmosphere's shared functions (issue 23), prepended to shaders/atmosphere_lut.frag (which
// fills the view tables each frame) and shaders/atmosphere.frag (which reads them per pixel).
// The geometry and texture maps are planet/src/AtmosphereGeometry.hpp's, line for line, in float;
// shaders/atmosphere_lut.frag's atmosphereRay() is AtmosphereTables::ray()
// (planet/src/AtmosphereLookup.cpp) without the phase functions. Keep them in step.
//
// Camera-relative: the eye's altitude and frame come from the CPU (double there); per pixel only a
// unit direction is in float. Everything is in the "sphere space" of an ellipsoidal body (the
// polar axis stretched by equatorial / polar radius).

uniform sampler2D uTransmittance; // (r, mu) -> the transmittance to the top
uniform vec4 uShell;    // bottom radius, top radius, top altitude, H = sqrt(top^2 - bottom^2), m
uniform vec4 uSizes;    // scattering table: nu, mu_s, mu, r sizes
uniform vec4 uTexSizes; // transmittance w, h; muSMin; Mie g
uniform float uEyeAltitude; // metres above the bottom (may exceed the top)
uniform float uMuS;         // the sun's zenith cosine at the eye
uniform vec4 uAirLut; // the aerial table: azimuth, zenith sizes, slices, log-map constant c

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

// The view ray's zenith map (Bruneton's u_mu at the eye, or where the ray enters the shell from
// above): x in [0, 1] within its half (ground: the ray reaches the bottom).
float zenithUnit(float h, float mu, bool ground) {
  float rho = rhoOf(h);
  if (ground) {
    float d = distanceToBottom(h, mu);
    float dMin = h, dMax = rho;
    return clamp(dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0, 0.0, 1.0);
  }
  float d = distanceToTop(h, mu);
  float dMin = topAlt() - h, dMax = rho + bigH();
  return clamp(dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0, 0.0, 1.0);
}
// The texture coordinate of that x on an axis of n texels, half for each kind of ray.
float zenithCoord(float x, bool ground, float n) {
  float half_ = n * 0.5;
  return ground ? 0.5 - 0.5 * unitToCoord(x, half_) : 0.5 + 0.5 * unitToCoord(x, half_);
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

float rayleighPhase(float nu) { return 3.0 / (16.0 * kPi) * (1.0 + nu * nu); }
float miePhase(float g, float nu) {
  float k = 3.0 / (8.0 * kPi) * (1.0 - g * g) / (2.0 + g * g);
  return k * (1.0 + nu * nu) / pow(max(1e-6, 1.0 + g * g - 2.0 * g * nu), 1.5);
}

// The view ray's entry into the shell and its length inside it (to the bottom or out through the
// top): t0 (0 when the eye is inside), t1 (>= t0), and the entry's (h, mu) for zenithUnit. sin2 =
// |dir x up|^2 (precise where mu is near -1 far from the body). False: the ray misses the shell.
bool viewSpan(float h, float mu, float sin2, out float t0, out float t1, out float he,
              out float mue, out bool ground) {
  t0 = 0.0;
  he = max(h, 0.0);
  mue = clampCos(mu);
  if (h > topAlt()) {
    float r = bottomR() + h;
    float p2 = r * r * sin2;
    if (mu >= 0.0 || p2 >= topR() * topR()) {
      t1 = 0.0;
      ground = false;
      return false;
    }
    float q = sqrt(topR() * topR() - p2);
    t0 = -r * mu - q;
    mue = -q / topR();
    he = topAlt();
  }
  ground = hitsGround(he, mue);
  t1 = t0 + (ground ? distanceToBottom(he, mue) : distanceToTop(he, mue));
  return true;
}

// The aerial slices' map: a distance's place x along [t0, t1] -> w in [0, 1], logarithmic from
// both ends (w = G(2x) / 2 up to the middle, 1 - G(2 (1 - x)) / 2 beyond, G(y) = log(1 + y (e^c
// - 1)) / c, c = uAirLut.w): slices dense near the eye, where the haze grows linearly with the
// distance, and near the ray's end, where from above it crosses the dense low air in its last
// kilometres (each slice about e^(2c / slices) times farther from its end).
float sliceUnit(float d, float t0, float t1) {
  float x = clamp((d - t0) / max(t1 - t0, 1e-3), 0.0, 1.0);
  float e = exp(uAirLut.w) - 1.0;
  return x <= 0.5 ? 0.5 * log(1.0 + 2.0 * x * e) / uAirLut.w
                  : 1.0 - 0.5 * log(1.0 + 2.0 * (1.0 - x) * e) / uAirLut.w;
}
// Its inverse: the place x of w.
float sliceDistance(float w) {
  float e = exp(uAirLut.w) - 1.0;
  return w <= 0.5 ? 0.5 * (exp(2.0 * w * uAirLut.w) - 1.0) / e
                  : 1.0 - 0.5 * (exp(2.0 * (1.0 - w) * uAirLut.w) - 1.0) / e;
}
