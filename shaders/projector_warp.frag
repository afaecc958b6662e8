// A projector channel's warp and blend on the GPU, pixel for pixel the CPU's
// (planet/src/ChannelWarp.cpp; conventions in planet/ChannelWarp.hpp): the projector pixel's centre
// placed in the warp mesh's grid (from the top left), its (u, v) interpolated bilinearly from the
// cell's four vertices (not by triangles: a quad's two triangles are not bilinear), the rendered
// image sampled there bilinearly (pixel centres at +0.5, clamped at the edges), the colour
// multiplied by the blend mask's weight; a render more than twice the projector's is the mean of
// uSamples x uSamples such samples spread over the pixel (ChannelWarp.hpp's warpSubsamples).
// GL's framebuffers are bottom-up: the projector's row from the top is uOut.y - gl_FragCoord.y,
// and the rendered image's row y is texel row uSource.y - 1 - y. The mesh (RG32F, uMeshSize.x x uMeshSize.y) and the mask (R32F) keep their
// rows from the top.
uniform sampler2D uRendered; // RGBA8, bottom-up (the scene's framebuffer copied)
uniform sampler2D uMesh;     // RG32F: (u, v) of vertex (i, j) at texel (i, j)
uniform sampler2D uBlend;    // R32F: the projector pixel's weight, rows from the top
uniform ivec2 uSource;       // the rendered image's size
uniform ivec2 uOut;          // the projector's size
uniform ivec2 uMeshSize;     // columns, rows (>= 2 each); 0: no warp
uniform int uHasBlend;
uniform int uSamples;        // N: the mean of N x N samples per pixel (warpSubsamples)
out vec4 fragColor;

vec4 texel(ivec2 p) {
  return texelFetch(uRendered, ivec2(p.x, uSource.y - 1 - p.y), 0);
}

// The rendered image sampled at the point (sx, sy) of the projector's image, from the top left.
vec4 sampleAt(float sx, float sy) {
  if (uMeshSize.x >= 2) {
    float gx = clamp(sx / float(uOut.x) * float(uMeshSize.x - 1), 0.0, float(uMeshSize.x - 1));
    float gy = clamp(sy / float(uOut.y) * float(uMeshSize.y - 1), 0.0, float(uMeshSize.y - 1));
    int i0 = min(int(gx), uMeshSize.x - 2);
    int j0 = min(int(gy), uMeshSize.y - 2);
    float fx = gx - float(i0), fy = gy - float(j0);
    vec2 a = texelFetch(uMesh, ivec2(i0, j0), 0).rg;
    vec2 b = texelFetch(uMesh, ivec2(i0 + 1, j0), 0).rg;
    vec2 c = texelFetch(uMesh, ivec2(i0, j0 + 1), 0).rg;
    vec2 d = texelFetch(uMesh, ivec2(i0 + 1, j0 + 1), 0).rg;
    vec2 uv = (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy;
    sx = uv.x * float(uSource.x);
    sy = uv.y * float(uSource.y);
  } else if (uSource != uOut) { // no warp: the rendered image scaled to the projector's
    sx = sx / float(uOut.x) * float(uSource.x);
    sy = sy / float(uOut.y) * float(uSource.y);
  }
  float x = clamp(sx - 0.5, 0.0, float(uSource.x - 1));
  float y = clamp(sy - 0.5, 0.0, float(uSource.y - 1));
  int x0 = int(x), y0 = int(y);
  int x1 = min(x0 + 1, uSource.x - 1), y1 = min(y0 + 1, uSource.y - 1);
  float fx = x - float(x0), fy = y - float(y0);
  return (texel(ivec2(x0, y0)) * (1.0 - fx) + texel(ivec2(x1, y0)) * fx) * (1.0 - fy) +
         (texel(ivec2(x0, y1)) * (1.0 - fx) + texel(ivec2(x1, y1)) * fx) * fy;
}

void main() {
  float left = gl_FragCoord.x - 0.5;               // the pixel's left edge
  float top = float(uOut.y) - gl_FragCoord.y - 0.5; // and top edge, from the top
  vec4 colour = vec4(0.0);
  for (int j = 0; j < uSamples; ++j)
    for (int i = 0; i < uSamples; ++i)
      colour += sampleAt(left + (float(i) + 0.5) / float(uSamples),
                         top + (float(j) + 0.5) / float(uSamples));
  colour /= float(uSamples * uSamples);
  if (uHasBlend != 0) {
    ivec2 p = ivec2(int(gl_FragCoord.x), uOut.y - 1 - int(gl_FragCoord.y));
    colour.rgb *= texelFetch(uBlend, p, 0).r;
  }
  fragColor = colour;
}
