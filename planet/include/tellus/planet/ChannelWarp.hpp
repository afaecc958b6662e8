#pragma once
/**
 * @file ChannelWarp.hpp
 * @brief A projector channel's warp and blend (issue 28, docs/design/cluster.md), applied to the
 * rendered image in a pass after rendering (on the CPU: the headless cluster's PNGs). GL-free.
 *
 * The warp mesh maps the projector's pixels onto the rendered image: a grid of columns x rows
 * vertices spread evenly over the projector's image (vertex (i, j) at x = i / (columns - 1) of its
 * width, y = j / (rows - 1) of its height, from the top left), each giving the point (u, v) of the
 * rendered image (0..1 across its width and height, from the top left) that the projector shows
 * there. A projector pixel's centre is placed in the grid, its (u, v) interpolated bilinearly, and
 * the rendered image sampled there bilinearly (clamped at the edges). The identity mesh (u = x,
 * v = y over images of one size) gives the rendered image back unchanged. A rendered image more
 * than twice the projector's along an axis is filtered down: each projector pixel is the mean of
 * N x N such samples spread evenly over it (warpSubsamples), so that no rendered pixel is skipped.
 * The blend mask, one weight in [0, 1] per projector pixel, then multiplies the colour (soft
 * edges where projectors overlap).
 */

#include <glm/vec2.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct WarpMesh {
  int columns = 2;            ///< >= 2
  int rows = 2;               ///< >= 2
  std::vector<glm::dvec2> uv; ///< rows x columns, row by row from the top
  /** The mesh that changes nothing: (u, v) = (x, y) at every vertex. */
  static WarpMesh identity(int columns = 2, int rows = 2);
};

/** RGBA8, rows from the top (what Renderer::readPixels gives). */
struct ChannelImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;
};

/** {"columns": C, "rows": R, "uv": [[u, v], ...]} (R x C pairs, finite). Refused with a message
 * naming origin and what is wrong. */
std::expected<WarpMesh, std::string> parseWarpMesh(std::string_view json,
                                                   std::string_view origin = "");
std::expected<WarpMesh, std::string> readWarpMesh(const std::filesystem::path& file);
/** A PNG's first channel as weights in [0, 1]; its size must be width x height. */
std::expected<std::vector<float>, std::string>
readBlendMask(const std::filesystem::path& file, int width, int height);

/** N, the samples per projector pixel along each axis: 1 while the rendered image is at most
 * twice the projector's along both axes (a bilinear sample at each pixel's centre then reads
 * every rendered pixel), else ceil(ratio / 2), at most 8: the N x N samples at (i + 0.5) / N
 * across the pixel, each bilinear over 2 x 2 rendered pixels, together cover its footprint (a
 * tent-filtered box; over a warp, the footprint of the mean scale). */
int warpSubsamples(int renderedWidth, int renderedHeight, int width, int height);

/** The projector's width x height image: the warp (null: none, the rendered image scaled to
 * that size: a projector pixel's centre at the same fraction of the rendered image), filtered as
 * warpSubsamples says, and the blend mask (null: none; else width x height weights). */
ChannelImage warpAndBlend(const ChannelImage& rendered,
                          int width,
                          int height,
                          const WarpMesh* warp,
                          const std::vector<float>* blend);

} // namespace tellus::planet
