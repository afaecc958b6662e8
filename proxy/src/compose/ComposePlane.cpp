// One plane composed (a JPEG map's Y, Cb or Cr, Compose.hpp's composePlane): per output row the
// vertical half of the bilinear filter once per tile column, then the horizontal half per pixel,
// with AVX2 or AVX-512 where the CPU has them; the same integer arithmetic as the RGB path.
#include "compose/ComposeSampling.hpp"

#include <cstdlib>
#include <cstring>
#include <utility>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TELLUS_COMPOSE_AVX2 1
#endif

namespace tellus {

namespace compose {

namespace {

/** Bilinear value of a quad of one-plane tiles. */
std::uint8_t sampleOne(const Quad& q) noexcept {
  const std::int32_t w[4] = {
      (256 - q.wx) * (256 - q.wy), q.wx * (256 - q.wy), (256 - q.wx) * q.wy, q.wx * q.wy};
  std::int32_t acc = 0;
  for (int k = 0; k < 4; ++k)
    acc += q.t[k]->rgb[q.index[k]] * w[k];
  return static_cast<std::uint8_t>((acc + 32768) >> 16);
}

/**
 * The horizontal half of the planar filter, precomputed per output column: out[i] = (v[xa] * wa +
 * v[xb] * wb + 32768) >> 16 over the vertically blended row v. Columns are grouped in segments of
 * a run of columns inside the layer; a segment of 8 columns whose texel pairs are neighbours
 * (xb = xa + 1, or wb = 0) within 16 texels of `base` is done with AVX2 (when the CPU has it)
 * straight from v: two unaligned loads of 16 texels (v[base..] and v[base + 1..]) interleaved into
 * the 16 pairs (v[x], v[x + 1]), two in-register permutations and a blend that pick each column's
 * pair, and one multiply-add of 16-bit pairs (pmaddwd) for v[xa] * wa + v[xb] * wb. pmaddwd
 * multiplies signed 16-bit values and v reaches 65,280, so the texels go in less 32,768 (the sign
 * bit flipped) and 32,768 * (wa + wb) = 2^23 is added back: exact, the same integer arithmetic as
 * the plain loop.
 */
struct Horizontal {
  enum class Kind : std::uint8_t {
    Scalar,
    Avx2,   ///< 8 columns within 16 texels
    Avx512, ///< 16 columns within 32 texels (xa - base <= 30)
  };
  struct Segment {
    std::uint32_t begin, end; ///< output columns
    std::uint32_t base;       ///< for a SIMD segment: its first texel in v
    Kind kind;
  };
  std::vector<std::uint32_t> xa, xb, wa, wb;
  /// AVX2 segments, per column: the pair's 32-bit lane in the interleaved registers (bits 0-2)
  /// and which of the two (bit 31), from r = xa - base: (r & 3) | (r & 8) >> 1, r & 4.
  std::vector<std::uint32_t> lane;
  /// AVX-512 segments, per column: the 16-bit indices of v[xa] and v[xa + 1] from the base, so
  /// that one permutation of 32 texels (vpermw) gives the 16 pairs.
  std::vector<std::uint16_t> pairIndex;
  std::vector<std::uint32_t> weights; ///< SIMD segments, per column: wa | wb << 16
  std::vector<Segment> segments;

  /// How far past the last texel of v the SIMD loads read (v must have these elements).
  static constexpr std::size_t kPadding = 32;

  void scalar(const std::uint16_t* v, std::uint8_t* out, std::size_t b, std::size_t e) const {
    for (std::size_t i = b; i < e; ++i)
      out[i] = static_cast<std::uint8_t>((v[xa[i]] * wa[i] + v[xb[i]] * wb[i] + 32768u) >> 16);
  }
  void run(const std::uint16_t* v, std::uint8_t* out) const;
};

#ifdef TELLUS_COMPOSE_AVX2
// TELLUS_COMPOSE_NO_AVX2=1 takes the plain code on any CPU, TELLUS_COMPOSE_NO_AVX512=1 the AVX2
// code on a CPU with AVX-512 (the tests run all three).
const bool kHasAvx2 = __builtin_cpu_supports("avx2") && !std::getenv("TELLUS_COMPOSE_NO_AVX2");
const bool kHasAvx512 =
    kHasAvx2 && __builtin_cpu_supports("avx512bw") && !std::getenv("TELLUS_COMPOSE_NO_AVX512");

/** One AVX2 segment (8 columns). */
[[gnu::always_inline]] inline __attribute__((target("avx2"))) void segmentAvx2(
    const Horizontal& h, const Horizontal::Segment& s, const std::uint16_t* v, std::uint8_t* out) {
  const __m256i flip = _mm256_set1_epi16(static_cast<short>(0x8000));
  const __m256i offset = _mm256_set1_epi32((1 << 23) + 32768);
  // The low byte of each 32-bit lane to the first four bytes of each 128-bit half, then those two
  // words side by side.
  // clang-format off
  const __m256i bytes = _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
                                         0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  // clang-format on
  const __m256i gather = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
  const __m256i v0 =
      _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + s.base)), flip);
  const __m256i v1 =
      _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + s.base + 1)), flip);
  // Pairs (v[x], v[x + 1]) for x = base + 0-3 | 8-11 (lo) and base + 4-7 | 12-15 (hi).
  const __m256i lo = _mm256_unpacklo_epi16(v0, v1);
  const __m256i hi = _mm256_unpackhi_epi16(v0, v1);
  const __m256i lane =
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(h.lane.data() + s.begin));
  const __m256 pick = _mm256_blendv_ps(_mm256_castsi256_ps(_mm256_permutevar8x32_epi32(lo, lane)),
                                       _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(hi, lane)),
                                       _mm256_castsi256_ps(lane));
  const __m256i sum = _mm256_madd_epi16(
      _mm256_castps_si256(pick),
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(h.weights.data() + s.begin)));
  const __m256i r = _mm256_permutevar8x32_epi32(
      _mm256_shuffle_epi8(_mm256_srli_epi32(_mm256_add_epi32(sum, offset), 16), bytes), gather);
  _mm_storel_epi64(reinterpret_cast<__m128i*>(out + s.begin), _mm256_castsi256_si128(r));
}

__attribute__((target("avx2"))) void
horizontalAvx2(const Horizontal& h, const std::uint16_t* v, std::uint8_t* out) {
  for (const Horizontal::Segment& s : h.segments) {
    if (s.kind == Horizontal::Kind::Avx2) {
      segmentAvx2(h, s, v, out);
    } else {
      h.scalar(v, out, s.begin, s.end);
    }
  }
}

/** With AVX-512 (BW), 16 columns at a time: 32 texels from the base in one register, one vpermw
 * for the 16 pairs, the same multiply-add. */
__attribute__((target("avx2,avx512f,avx512bw"))) void
horizontalAvx512(const Horizontal& h, const std::uint16_t* v, std::uint8_t* out) {
  const __m512i flip = _mm512_set1_epi16(static_cast<short>(0x8000));
  const __m512i offset = _mm512_set1_epi32((1 << 23) + 32768);
  const __mmask16 all = 0xFFFF;
  for (const Horizontal::Segment& s : h.segments) {
    if (s.kind == Horizontal::Kind::Avx512) {
      const __m512i texels = _mm512_xor_si512(_mm512_loadu_si512(v + s.base), flip);
      const __m512i pairs = _mm512_permutexvar_epi16(
          _mm512_loadu_si512(h.pairIndex.data() + 2 * static_cast<std::size_t>(s.begin)), texels);
      const __m512i sum = _mm512_madd_epi16(pairs, _mm512_loadu_si512(h.weights.data() + s.begin));
      // The zero-masked forms: GCC 12's plain ones start from an "undefined" register that
      // -Wmaybe-uninitialized flags.
      const __m512i r = _mm512_maskz_srli_epi32(all, _mm512_add_epi32(sum, offset), 16);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + s.begin),
                       _mm512_maskz_cvtepi32_epi8(all, r));
    } else if (s.kind == Horizontal::Kind::Avx2) {
      segmentAvx2(h, s, v, out);
    } else {
      h.scalar(v, out, s.begin, s.end);
    }
  }
}
#endif

void Horizontal::run(const std::uint16_t* v, std::uint8_t* out) const {
#ifdef TELLUS_COMPOSE_AVX2
  if (kHasAvx512) return horizontalAvx512(*this, v, out);
  if (kHasAvx2) return horizontalAvx2(*this, v, out);
#endif
  for (const Segment& s : segments)
    scalar(v, out, s.begin, s.end);
}

/** The vertical half of the filter over one texel row of a tile column: a plain loop that the
 * compiler vectorises, inlined once more into an AVX2 function used where the CPU has it
 * (dispatched at run time like the horizontal pass; not with target_clones, whose ifunc resolvers
 * run before ThreadSanitizer's runtime is up). */
[[gnu::always_inline]] inline void blendRowsLoop(const std::uint8_t* a,
                                                 const std::uint8_t* b,
                                                 std::uint32_t wy,
                                                 std::uint16_t* out,
                                                 std::size_t n) noexcept {
  for (std::size_t x = 0; x < n; ++x)
    out[x] = static_cast<std::uint16_t>(a[x] * (256u - wy) + b[x] * wy);
}

#ifdef TELLUS_COMPOSE_AVX2
__attribute__((target("avx2"))) void blendRowsAvx2(const std::uint8_t* a,
                                                   const std::uint8_t* b,
                                                   std::uint32_t wy,
                                                   std::uint16_t* out,
                                                   std::size_t n) noexcept {
  blendRowsLoop(a, b, wy, out, n);
}
#endif

void blendRows(const std::uint8_t* a,
               const std::uint8_t* b,
               std::uint32_t wy,
               std::uint16_t* out,
               std::size_t n) noexcept {
#ifdef TELLUS_COMPOSE_AVX2
  if (kHasAvx2) return blendRowsAvx2(a, b, wy, out, n);
#endif
  blendRowsLoop(a, b, wy, out, n);
}

/** Where each tile column's sampled texels [lo, hi] start in the blended row of a plane
 * (composePlaneInto), and (`span`) the row's length. */
std::vector<std::uint32_t> columnBases(const Axis& cols, std::uint32_t& span) {
  std::vector<std::uint32_t> base(cols.tiles.size(), 0);
  span = 0;
  for (std::size_t k = 0; k < cols.tiles.size(); ++k) {
    base[k] = span;
    if (cols.hi[k] >= cols.lo[k]) span += static_cast<std::uint32_t>(cols.hi[k] - cols.lo[k] + 1);
  }
  return base;
}

/** The horizontal half of a plane's filter per output column: the two texels in the blended
 * row and their weights; and the runs of columns inside the layer [begin, end). */
std::vector<std::pair<std::int32_t, std::int32_t>>
horizontalTexels(const Axis& cols, const std::vector<std::uint32_t>& base, Horizontal& hz) {
  const std::size_t w = cols.samples.size();
  hz.xa.assign(w, 0);
  hz.xb.assign(w, 0);
  hz.wa.assign(w, 0);
  hz.wb.assign(w, 0);
  hz.lane.assign(w, 0);
  hz.weights.assign(w, 0);
  std::vector<std::uint32_t>&xa = hz.xa, &xb = hz.xb, &wa = hz.wa, &wb = hz.wb;
  std::vector<std::pair<std::int32_t, std::int32_t>> runs;
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(w); ++i) {
    const AxisSample& c = cols.samples[static_cast<std::size_t>(i)];
    if (c.slotA < 0) continue;
    const auto ka = static_cast<std::size_t>(c.slotA), kb = static_cast<std::size_t>(c.slotB);
    const auto ui = static_cast<std::size_t>(i);
    xa[ui] = base[ka] + static_cast<std::uint32_t>(c.offA - cols.lo[ka]);
    xb[ui] = base[kb] + static_cast<std::uint32_t>(c.offB - cols.lo[kb]);
    wb[ui] = static_cast<std::uint32_t>(c.weightB);
    if (xb[ui] == xa[ui]) wb[ui] = 0; // one texel (clamped at an edge): the same value
    wa[ui] = 256u - wb[ui];
    if (!runs.empty() && runs.back().second == i) {
      runs.back().second = i + 1;
    } else {
      runs.emplace_back(i, i + 1);
    }
  }
  return runs;
}

/** The runs of columns cut into segments: 16 columns by AVX-512 or 8 by AVX2 where their texel
 * pairs are neighbours close enough together, the rest scalar. */
void planSegments(const std::vector<std::pair<std::int32_t, std::int32_t>>& runs, Horizontal& hz) {
#ifdef TELLUS_COMPOSE_AVX2
  const bool wide = kHasAvx512;
#else
  const bool wide = false;
#endif
  const std::vector<std::uint32_t>&xa = hz.xa, &xb = hz.xb, &wa = hz.wa, &wb = hz.wb;
  if (wide) hz.pairIndex.assign(2 * xa.size(), 0);
  // Whether columns [i, i + n) can be one SIMD segment of n columns (texel pairs that are
  // neighbours within `reach` texels of the first); the first texel when they can.
  const auto fits = [&](std::uint32_t i, std::uint32_t n, std::uint32_t reach, std::uint32_t& lo) {
    std::uint32_t hi = xa[i];
    lo = xa[i];
    bool neighbours = true;
    for (std::uint32_t k = i; k < i + n; ++k) {
      lo = std::min(lo, xa[k]);
      hi = std::max(hi, xa[k]);
      neighbours = neighbours && (xb[k] == xa[k] + 1 || wb[k] == 0);
    }
    return neighbours && hi - lo < reach;
  };
  const auto add =
      [&](std::uint32_t begin, std::uint32_t end, std::uint32_t first, Horizontal::Kind kind) {
        if (kind == Horizontal::Kind::Scalar && !hz.segments.empty() &&
            hz.segments.back().kind == Horizontal::Kind::Scalar &&
            hz.segments.back().end == begin) {
          hz.segments.back().end = end;
        } else {
          hz.segments.push_back({begin, end, first, kind});
        }
      };
  for (const auto& [begin, end] : runs) {
    auto i = static_cast<std::uint32_t>(begin);
    const auto e = static_cast<std::uint32_t>(end);
    std::uint32_t lo = 0;
    while (i + 8 <= e) {
      if (wide && i + 16 <= e && fits(i, 16, 31, lo)) {
        for (std::uint32_t k = i; k < i + 16; ++k) {
          const std::uint32_t r = xa[k] - lo;
          hz.pairIndex[2 * k] = static_cast<std::uint16_t>(r);
          hz.pairIndex[2 * k + 1] = static_cast<std::uint16_t>(r + 1);
          hz.weights[k] = wa[k] | wb[k] << 16;
        }
        add(i, i + 16, lo, Horizontal::Kind::Avx512);
        i += 16;
        continue;
      }
      if (fits(i, 8, 16, lo)) {
        for (std::uint32_t k = i; k < i + 8; ++k) {
          const std::uint32_t r = xa[k] - lo;
          hz.lane[k] = (r & 3u) | (r & 8u) >> 1 | (r & 4u ? 0x80000000u : 0u);
          hz.weights[k] = wa[k] | wb[k] << 16;
        }
        add(i, i + 8, lo, Horizontal::Kind::Avx2);
      } else {
        add(i, i + 8, 0, Horizontal::Kind::Scalar);
      }
      i += 8;
    }
    if (i < e) add(i, e, 0, Horizontal::Kind::Scalar);
  }
}

/** The vertical half of one output row of a plane: each tile column's two texel rows blended
 * into `blended` at its base; `present` says which tile columns have both tiles. True when every
 * tile column the map samples has them. */
bool blendPlaneRow(const LevelTiles& t,
                   const AxisSample& r,
                   const std::vector<std::uint32_t>& base,
                   std::vector<std::uint16_t>& blended,
                   std::vector<char>& present) {
  const auto wy = static_cast<std::uint32_t>(r.weightB);
  bool all = true;
  for (std::size_t k = 0; k < t.cols.tiles.size(); ++k) {
    const TileSamples* sa = t.at(r.slotA, static_cast<std::int32_t>(k));
    const TileSamples* sb = t.at(r.slotB, static_cast<std::int32_t>(k));
    present[k] = sa && sb && t.cols.hi[k] >= 0;
    if (!present[k]) {
      all = all && t.cols.hi[k] < 0;
      continue;
    }
    const std::uint8_t* a =
        sa->rgb + static_cast<std::size_t>(r.offA) * static_cast<std::size_t>(sa->width);
    const std::uint8_t* b =
        sb->rgb + static_cast<std::size_t>(r.offB) * static_cast<std::size_t>(sb->width);
    const auto lo = static_cast<std::size_t>(t.cols.lo[k]);
    const std::size_t n = static_cast<std::size_t>(t.cols.hi[k]) + 1 - lo;
    blendRows(a + lo, b + lo, wy, blended.data() + base[k], n);
  }
  return all;
}

/** The horizontal half of a row of a plane where a tile is missing: pixel by pixel, the missing
 * ones from the coarser level (or the background, or left). */
void samplePlaneRowWithHoles(const LevelTiles& t,
                             const Horizontal& hz,
                             const std::uint16_t* v,
                             const std::vector<char>& present,
                             Fallback& fallback,
                             std::int32_t j,
                             const std::uint8_t* background,
                             std::uint8_t* out,
                             ComposeStats& stats) {
  Quad q{};
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(t.cols.samples.size()); ++i) {
    const AxisSample& c = t.cols.samples[static_cast<std::size_t>(i)];
    if (c.slotA < 0) continue;
    const auto ui = static_cast<std::size_t>(i);
    if (present[static_cast<std::size_t>(c.slotA)] && present[static_cast<std::size_t>(c.slotB)]) {
      out[ui] = static_cast<std::uint8_t>(
          (v[hz.xa[ui]] * hz.wa[ui] + v[hz.xb[ui]] * hz.wb[ui] + 32768u) >> 16);
    } else if (fallback.quad(i, j, q)) { // a tile of the four is missing at this level
      ++stats.fallbackPixels;
      out[ui] = sampleOne(q);
    } else {
      ++stats.missingPixels;
      if (background) out[ui] = *background;
    }
  }
}

} // namespace

/**
 * composeImagery for one plane (tiles and canvas of one channel, opaque). Per output row, the
 * vertical half of the filter once per tile column into one row of the texels the map samples
 * (the tile columns side by side), then the horizontal half per pixel as two loads from that row:
 * no test per pixel while every tile of the row is there. The same integer arithmetic as the RGB
 * path's (weights in 1/256, one rounding), so the same values.
 */
ComposeStats composePlaneInto(const TileGrid& grid,
                              const MapBox& box,
                              std::int32_t width,
                              std::int32_t height,
                              std::int32_t level,
                              std::int32_t firstLevel,
                              const TileLookup& tiles,
                              const std::uint8_t* background,
                              std::uint8_t* canvas) {
  if (const std::int32_t s = columnSamples(grid, box, width, level); s > 1) {
    // With a background every sample of the band's rows is written.
    return composeWide(
        box,
        width,
        height,
        s,
        1,
        background == nullptr,
        canvas,
        [&](const MapBox& b, std::int32_t w, std::int32_t h, std::vector<std::uint8_t>& wide) {
          return composePlaneInto(grid, b, w, h, level, firstLevel, tiles, background, wide.data());
        });
  }
  ComposeStats stats;
  const LevelTiles t = levelTiles(grid, box, width, height, level, tiles);
  Fallback fallback(grid, box, width, height, level, std::max(0, firstLevel), tiles);
  std::uint32_t span = 0;
  const std::vector<std::uint32_t> base = columnBases(t.cols, span);
  Horizontal hz;
  planSegments(horizontalTexels(t.cols, base, hz), hz);
  // + 1: v[x + 1] of the last pair; the SIMD loads read up to 32 texels from a base <= span - 1.
  std::vector<std::uint16_t> blended(span + 1 + Horizontal::kPadding);
  std::vector<char> present(t.cols.tiles.size());
  // With a background, the columns outside the layer are filled in each row drawn.
  const bool outsideColumns =
      background && std::any_of(t.cols.samples.begin(),
                                t.cols.samples.end(),
                                [](const AxisSample& c) { return c.slotA < 0; });
  const auto w = static_cast<std::size_t>(width);
  for (std::int32_t j = std::max(0, box.rowBegin); j < std::min(height, box.rowEnd); ++j) {
    const AxisSample& r = t.rows.samples[static_cast<std::size_t>(j)];
    std::uint8_t* out = canvas + static_cast<std::size_t>(j) * w;
    if (r.slotA < 0 || outsideColumns) {
      if (background) std::memset(out, *background, w);
      if (r.slotA < 0) continue;
    }
    if (blendPlaneRow(t, r, base, blended, present))
      hz.run(blended.data(), out);
    else
      samplePlaneRowWithHoles(t, hz, blended.data(), present, fallback, j, background, out, stats);
  }
  return stats;
}

} // namespace compose

ComposeStats composePlane(const TileGrid& grid,
                          const MapBox& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t level,
                          std::int32_t firstLevel,
                          const TileLookup& tiles,
                          std::uint8_t background,
                          std::vector<std::uint8_t>& plane) {
  plane.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  return compose::composePlaneInto(
      grid, box, width, height, level, firstLevel, tiles, &background, plane.data());
}

} // namespace tellus
