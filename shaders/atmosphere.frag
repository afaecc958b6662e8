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
//
// Three forms (AtmospherePass.hpp): at full resolution (no define); at 1/2 or 1/4 of it
// (TELLUS_ATMOSPHERE_SPLIT: the display value, the factor, the transmittance to space and the
// depth's key into three textures); and the composite over the target
// (TELLUS_ATMOSPHERE_COMPOSITE) that spreads those textures (bilinear) where the pixel's own
// depth agrees with theirs, computes the pixel in full where it does not (the limb, silhouettes
// against the sky or far terrain: no soft edge there), and draws the sun's disc at full
// resolution.
in vec2 vNdc;
in vec4 vRay; // flat: the inverse view-projection of the pixel (shaders/atmosphere.vert)
#ifdef TELLUS_ATMOSPHERE_SPLIT
layout(location = 0) out vec4 outGlow; // rgb: the display value; a: the depth's key
layout(location = 1) out vec4 outFactor;
layout(location = 2) out vec4 outSunLight; // rgb: the transmittance where the ray reaches space
#else
layout(location = 0, index = 0) out vec4 outColor;
layout(location = 0, index = 1) out vec4 outFactor;
#endif
#ifdef TELLUS_ATMOSPHERE_COMPOSITE
uniform sampler2D uGlow; // the split form's three textures
uniform sampler2D uFactor;
uniform sampler2D uSunLight;
#endif
uniform int uDivisor; // the split form: target pixels per texel along x and y
uniform vec2 uTarget; // the target's width and height in pixels
uniform mat4 uInvViewProj; // clip -> world, rotation only (shaders/atmosphere.vert)

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

// The ray through a point of normalised device coordinates, not normalised: flat, from the
// inverse view-projection (ray4: its value there, interpolated by the vertex shader or computed);
// the fisheye's from its map. False outside the dome's circle.
bool rayAt(vec2 ndc, vec4 ray4, out vec3 ray) {
  if (uFisheye != 0) {
    vec2 v = ndc / uFisheyeMap.xy; // radians, along the image's x and y
    float theta = length(v);
    ray = vec3(0.0, 0.0, -1.0);
    if (theta > uFisheyeMap.z + 0.05) return false;
    vec2 side = theta > 0.0 ? v / theta : vec2(0.0);
    ray = normalize(uDomeToWorld * vec3(side * sin(theta), -cos(theta)));
  } else {
    ray = ray4.xyz * sign(ray4.w);
  }
  return true;
}

// The distance along the ray in sphere space to what the globe drew (from its depth: near / depth
// along the view axis, flat, or along the ray, fisheye, stretched with the ray: |S ray| /
// (ray . forward) per unit of the axis); -1: nothing drawn. sdir: the ray's unit direction there.
float distanceOf(vec3 ray, float depth, out vec3 sdir) {
  vec3 sray = uScale * ray;
  float slen = length(sray);
  sdir = sray / slen;
  if (depth <= 0.0) return -1.0;
  float nd = uClipControl != 0 ? depth : 2.0 * depth - 1.0;
  float along = uNear / max(nd, 1e-30);
  return uFisheye != 0 ? along * slen : along * slen / max(dot(ray, uForward), 1e-30);
}

// The key the composite compares depths by: log2 of the distance along the view axis (the ray,
// fisheye) / 32 (0.125 of a doubling per 8-bit step), 1 where the globe drew nothing.
float depthKey(float depth) {
  if (depth <= 0.0) return 1.0;
  float nd = uClipControl != 0 ? depth : 2.0 * depth - 1.0;
  return clamp(log2(max(uNear / max(nd, 1e-30), 1.0)) / 32.0, 0.0, 0.99);
}

// The air along a ray to `distance` (-1: to space or the ground): the inscatter's radiance without
// the sun's disc, the transmittance, and whether the ray reaches space.
vec3 airAlong(vec3 sdir, float distance, out vec3 transmittance, out bool seesSpace) {
  float nu = dot(sdir, uSun);
  vec3 rayleigh = vec3(0.0), mie = vec3(0.0);
  transmittance = vec3(1.0);
  seesSpace = distance < 0.0;
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
  return rayleigh * rayleighPhase(nu) + mie * miePhase(uTexSizes.w, nu);
}

// Display: 1 - exp(-exposure L) (a soft shoulder), then gamma 2.2; the terrain behind is already
// display-encoded, so its factor is the transmittance's gamma-encoded value, leaving room for the
// inscatter (a screen blend: the sum never exceeds 1).
vec3 display(vec3 radiance) {
  return pow(vec3(1.0) - exp(-uSunDisc.z * radiance), vec3(1.0 / 2.2));
}
vec3 factorOf(vec3 transmittance, vec3 glow) {
  return pow(transmittance, vec3(1.0 / 2.2)) * (vec3(1.0) - glow);
}

// The sun's disc's radiance along a ray that reaches space, dimmed by the air.
vec3 discOf(vec3 sdir, vec3 transmittance) {
  return dot(sdir, uSun) > uSunDisc.x ? transmittance * uSolar * uSunDisc.y : vec3(0.0);
}

#ifdef TELLUS_ATMOSPHERE_COMPOSITE
// The pixel from the split pass's textures when it may be (outColor and outFactor written: true):
// the depth compared by key only, the ray made only for the sun's disc.
bool fromLowerResolution(float depth) {
  // Texel i stands for pixel centre i * divisor + 0.5: this pixel's place t among the texels,
  // the four around it.
  vec2 t = (gl_FragCoord.xy - 0.5) / float(uDivisor);
  ivec2 size = textureSize(uGlow, 0);
  ivec2 i0 = clamp(ivec2(floor(t)), ivec2(0), size - 1), i1 = min(i0 + 1, size - 1);
  vec2 f = clamp(t - floor(t), 0.0, 1.0);
  vec4 g00 = texelFetch(uGlow, i0, 0), g10 = texelFetch(uGlow, ivec2(i1.x, i0.y), 0);
  vec4 g01 = texelFetch(uGlow, ivec2(i0.x, i1.y), 0), g11 = texelFetch(uGlow, i1, 0);
  // The lower resolution where the four texels' depths agree with this pixel's (within 0.6 of a
  // doubling of the distance, or all sky) and their values are close (within 0.08 of the display
  // range, 20 levels: not the limb's thin glow nor the horizon); in full where not.
  float key = depthKey(depth);
  vec4 keys = abs(vec4(g00.a, g10.a, g01.a, g11.a) - key);
  vec3 spread = max(max(g00.rgb, g10.rgb), max(g01.rgb, g11.rgb)) -
                min(min(g00.rgb, g10.rgb), min(g01.rgb, g11.rgb));
  if (max(max(keys.x, keys.y), max(keys.z, keys.w)) < 0.6 / 32.0 &&
      max(spread.r, max(spread.g, spread.b)) < 0.08) {
    vec2 uv = (t + 0.5) / vec2(size);
    vec3 glow = mix(mix(g00.rgb, g10.rgb, f.x), mix(g01.rgb, g11.rgb, f.x), f.y);
    vec3 factor = texture(uFactor, uv).rgb;
    vec4 light = texture(uSunLight, uv);
    vec3 ray;
    if (light.a > 0.0 && rayAt(vNdc, vRay, ray)) {
      vec3 sdir = normalize(uScale * ray);
      if (dot(sdir, uSun) > uSunDisc.x) {
        // The disc added to the sky's radiance before the display map: 1 - exp(-e (S + D)) =
        // 1 - (1 - s) exp(-e D), with s the sky's value before the gamma; tr: the
        // transmittance (the texture's rgb is weighted by a where sky and ground meet).
        vec3 tr = light.rgb / light.a;
        vec3 sky = pow(glow, vec3(2.2));
        vec3 lit = vec3(1.0) - (vec3(1.0) - sky) * exp(-uSunDisc.z * discOf(sdir, tr));
        lit = pow(lit, vec3(1.0 / 2.2));
        glow = mix(glow, lit, light.a);
        factor = mix(factor, factorOf(tr, lit), light.a);
      }
    }
    outColor = vec4(glow, 0.0);
    outFactor = vec4(factor, 1.0);
    return true;
  }
  return false;
}
#endif

void main() {
#ifdef TELLUS_ATMOSPHERE_COMPOSITE
  if (fromLowerResolution(texelFetch(uDepth, ivec2(gl_FragCoord.xy), 0).r)) return;
#endif
  vec3 ray;
#ifdef TELLUS_ATMOSPHERE_SPLIT
  // A texel stands for the target's pixel at its block's lower left corner, its ray and its
  // depth together: the haze over the ground is steep in the distance near the ray's end, so a
  // ray and a depth of different pixels would disagree (the composite interpolates accordingly).
  vec2 px = floor(gl_FragCoord.xy) * float(uDivisor) + 0.5;
  vec2 ndc = px / uTarget * 2.0 - 1.0;
  bool inside = rayAt(ndc, uInvViewProj * vec4(ndc, 1.0, 1.0), ray);
#else
  bool inside = rayAt(vNdc, vRay, ray);
#endif
  if (!inside) { // outside the dome's circle: nothing
#ifdef TELLUS_ATMOSPHERE_SPLIT
    outGlow = vec4(0.0, 0.0, 0.0, 1.0);
    outFactor = vec4(1.0);
    outSunLight = vec4(0.0);
#else
    outColor = vec4(0.0);
    outFactor = vec4(1.0);
#endif
    return;
  }
  vec3 sdir, transmittance;
  bool seesSpace;
#ifdef TELLUS_ATMOSPHERE_SPLIT
  float depth = texelFetch(uDepth, ivec2(px), 0).r;
  float distance = distanceOf(ray, depth, sdir);
  vec3 glow = display(airAlong(sdir, distance, transmittance, seesSpace));
  outGlow = vec4(glow, depthKey(depth));
  outFactor = vec4(factorOf(transmittance, glow), 1.0);
  outSunLight = seesSpace ? vec4(transmittance, 1.0) : vec4(0.0);
#else
  float depth = texelFetch(uDepth, ivec2(gl_FragCoord.xy), 0).r;
  float distance = distanceOf(ray, depth, sdir);
  vec3 inscatter = airAlong(sdir, distance, transmittance, seesSpace);
  if (seesSpace) inscatter += discOf(sdir, transmittance);
  vec3 glow = display(inscatter);
  outColor = vec4(glow, 0.0);
  outFactor = vec4(factorOf(transmittance, glow), 1.0);
#endif
}
