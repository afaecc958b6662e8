#pragma once
/**
 * @file GpuVertex.hpp
 * @brief The vertex format the GL layer uploads, built on the CPU (issue #8: no NaN or inf
 * anywhere in positions, normals or texture coordinates, asserted in debug builds).
 *
 * 15 floats (60 bytes) a vertex: the ECEF position as three doubles (six floats' worth of bytes,
 * OpenGL 4.x, `dvec3`) or as a high and a low float per coordinate (OpenGL 3.3: the shader
 * computes (high - eyeHigh) + (low - eyeLow)), then the unit normal and the node's texture
 * coordinates as floats, then geomorphing's offset to the parent's position (metres, small: a
 * float is exact to 1e-7 of it, added camera-relative) and the parent's extent (Morph.hpp).
 * Pure functions; no GL.
 */

#include <tellus/planet/Terrain.hpp>
#include <tellus/planet/TextureFallback.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <span>
#include <vector>

namespace tellus::planet {

inline constexpr std::size_t kFloatsPerVertex = 15;

/** A double as two floats: high = float(v), low = float(v - high). |v - (high + low)| is at most
 * half a float ulp of the low part (about 3e-9 m at the Earth's radius, where high's ulp is 0.5 m).
 * Non-finite input stays non-finite (callers assert against it). */
struct SplitDouble {
  float high = 0.0f;
  float low = 0.0f;
};
SplitDouble splitDouble(double v) noexcept;

enum class VertexPositions {
  Doubles,    ///< three doubles (the shader's dvec3; GL 4.x)
  FloatPairs, ///< high and low floats (GL 3.3)
};

/** Appends vertices to out in the GL layer's format. Debug builds assert, for every vertex, a
 * finite position, a finite unit normal (|n| within 1e-3 of 1), texture coordinates in [0, 1], and
 * (FloatPairs) that high + low gives the position back within 1e-6 relative. */
void packVertices(std::span<const TerrainVertex> vertices,
                  VertexPositions mode,
                  std::vector<float>& out);

/** The camera-relative position the vertex shader computes from a FloatPairs vertex (its six
 * position floats) and the eye, in float as the GPU does ((high - eyeHigh) + (low - eyeLow)); for
 * the precision tests and benchmarks. */
glm::vec3 eyeRelativeFloatPairs(const float* packedPosition, const glm::dvec3& eye) noexcept;

/** The uv transform as the four floats of the shader's uniform (scale.xy, offset.xy); debug
 * builds assert that they are finite. */
std::array<float, 4> uvUniform(const UvTransform& uv) noexcept;

} // namespace tellus::planet
