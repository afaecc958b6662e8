// The atmosphere's view tables (issue 23; planet/gl/src/AtmospherePass.cpp), after Hillaire's
// (2020) sky-view and aerial-perspective tables: for the eye's altitude and the sun's elevation,
// per texel one view direction (azimuth from the sun's, zenith by Bruneton's map) and, in the
// aerial table, one distance along it; the sky along that ray from Bruneton's (2017) precomputed
// tables (planet/include/tellus/planet/Atmosphere.hpp) as AtmosphereTables::ray() computes it,
// without the phase functions (applied per pixel, where nu is exact). Prepended by
// shaders/atmosphere_common.glsl. One draw per table (the sky's, 2D) or per slice (the aerial
// table's, a layer of a 3D texture); three targets: Rayleigh (with the multiple scattering), Mie,
// transmittance.
layout(location = 0) out vec4 outRayleigh;
layout(location = 1) out vec4 outMie;
layout(location = 2) out vec4 outTransmittance;

uniform sampler3D uScattering; // Rayleigh + multiple (divided by the Rayleigh phase)
uniform sampler3D uMie;
uniform vec4 uLut; // this table: azimuth size, zenith size, slices (0: the sky's), this slice

// The log of one mu_s row (clamped to the table) of a nu slice, at (umu, ur).
vec3 muSRow(sampler3D t, float slice, float i, float umu, float ur) {
  float c = clamp(i, 0.0, uSizes.y - 1.0);
  vec3 v = texture(t, vec3((slice + (c + 0.5) / uSizes.y) / uSizes.x, umu, ur)).rgb;
  return log(max(v, vec3(1e-20)));
}
vec3 alongMuS(sampler3D t, float slice, float im, float f, float umu, float ur) {
  vec3 p0 = muSRow(t, slice, im - 1.0, umu, ur), p1 = muSRow(t, slice, im, umu, ur);
  vec3 p2 = muSRow(t, slice, im + 1.0, umu, ur), p3 = muSRow(t, slice, im + 2.0, umu, ur);
  float f2 = f * f, f3 = f2 * f;
  vec3 v = 0.5 * (2.0 * p1 + (p2 - p0) * f + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f2 +
                  (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * f3);
  return exp(clamp(v, min(p1, p2), max(p1, p2)));
}

void lookupScattering(float h, float mu, float muS, float nu, bool ground, out vec3 rayleigh,
                      out vec3 mie) {
  float rho = rhoOf(h);
  float ur = unitToCoord(clamp(rho / bigH(), 0.0, 1.0), uSizes.w);
  float umu = zenithCoord(zenithUnit(h, mu, ground), ground, uSizes.z);
  float dMin = topAlt(), dMax = bigH();
  float a = (distanceToTop(0.0, muS) - dMin) / (dMax - dMin);
  float A = (distanceToTop(0.0, uTexSizes.z) - dMin) / (dMax - dMin);
  float umus = unitToCoord(clamp(max(1.0 - a / A, 0.0) / (1.0 + a), 0.0, 1.0), uSizes.y);
  float x = clamp((nu + 1.0) / 2.0, 0.0, 1.0) * (uSizes.x - 1.0);
  float slice = min(floor(x), uSizes.x - 2.0);
  float f = x - slice;
  // Along mu_s: Catmull-Rom through the logarithms of the four nearest rows, held between the
  // middle two (AtmosphereLookup.cpp's lookupScattering: no kinks at the rows, which showed as
  // bands parallel to the terminator with a linear blend).
  float xm = umus * uSizes.y - 0.5;
  float im = floor(xm);
  float fm = xm - im;
  rayleigh = mix(alongMuS(uScattering, slice, im, fm, umu, ur),
                 alongMuS(uScattering, slice + 1.0, im, fm, umu, ur), f);
  mie = mix(alongMuS(uMie, slice, im, fm, umu, ur), alongMuS(uMie, slice + 1.0, im, fm, umu, ur), f);
}

// The sky along a ray (AtmosphereTables::ray without the phases): distance < 0: to the shell's
// end (the ground or space).
void atmosphereRay(float h, float mu, float sin2, float muS, float nu, float distance,
                   out vec3 rayleigh, out vec3 mie, out vec3 transmittance) {
  rayleigh = vec3(0.0);
  mie = vec3(0.0);
  transmittance = vec3(1.0);
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
  } else {
    transmittance = ground ? vec3(0.0) : transmittanceToTop(h, mu);
  }
}

void main() {
  vec2 ij = floor(gl_FragCoord.xy);
  // The azimuth from the sun's (0) to the opposite (pi): u = sin(phi / 2).
  float u = ij.x / (uLut.x - 1.0);
  float cosPhi = 1.0 - 2.0 * u * u;
  // The zenith: Bruneton's map at the eye (or at the shell's top for an eye above it).
  float half_ = uLut.y * 0.5;
  bool ground = ij.y < half_;
  float x = ground ? (half_ - 1.0 - ij.y) / (half_ - 1.0) : (ij.y - half_) / (half_ - 1.0);
  float h = max(uEyeAltitude, 0.0);
  float he = min(h, topAlt());
  float rho = rhoOf(he), r = bottomR() + he;
  float mue;
  if (ground) {
    float d = he + x * (rho - he);
    mue = d <= 0.0 ? -1.0 : clampCos(-(rho * rho + d * d) / (2.0 * r * d));
  } else {
    float d = (topAlt() - he) + x * (rho + bigH() - (topAlt() - he));
    // At the top (rho = H) the chord d leaves at mu = -d / 2r: 0 for d = 0, which from above is
    // the ray that grazes the top (not the zenith, as the general form's d = 0 would say).
    if (he >= topAlt())
      mue = -d / (2.0 * r);
    else
      mue = d <= 0.0 ? 1.0 : clampCos((bigH() * bigH() - rho * rho - d * d) / (2.0 * r * d));
  }
  float mu, sin2;
  if (h > topAlt()) { // the ray that enters the top at mue: its impact parameter p
    float p2 = topR() * topR() * max(0.0, (1.0 - mue) * (1.0 + mue));
    float re = bottomR() + h;
    sin2 = min(1.0, p2 / (re * re));
    mu = -sqrt(1.0 - sin2);
  } else {
    mu = mue;
    sin2 = max(0.0, (1.0 - mu) * (1.0 + mu));
  }
  float nu = clampCos(mu * uMuS + sqrt(sin2) * cosPhi * sqrt(max(0.0, 1.0 - uMuS * uMuS)));
  vec3 rayleigh, mie, transmittance;
  if (uLut.z < 1.0) {
    atmosphereRay(h, mu, sin2, uMuS, nu, -1.0, rayleigh, mie, transmittance);
  } else {
    float t0, t1, hx, mux;
    bool g;
    viewSpan(h, mu, sin2, t0, t1, hx, mux, g);
    float w = uLut.w / (uLut.z - 1.0);
    float d = w >= 1.0 ? t1 : t0 + sliceDistance(w) * (t1 - t0);
    if (d <= 0.0) {
      rayleigh = vec3(0.0);
      mie = vec3(0.0);
      transmittance = vec3(1.0);
    } else {
      atmosphereRay(h, mu, sin2, uMuS, nu, d, rayleigh, mie, transmittance);
    }
  }
  outRayleigh = vec4(rayleigh, 1.0);
  outMie = vec4(mie, 1.0);
  outTransmittance = vec4(transmittance, 1.0);
}
