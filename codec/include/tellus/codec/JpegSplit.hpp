#pragma once
// Cutting a JPEG into tiles in the DCT domain (like `jpegtran -crop`, our own code on
// libjpeg-turbo's coefficient API): the entropy-coded blocks are read once and each tile's blocks
// are written as a JPEG of its own, with the same quantisation tables and sampling. No colour
// conversion, no (inverse) DCT, no quantisation: the tiles decode to exactly the pixels of the
// whole image's decode, cropped. Used to split a metatile fetched from a WMS upstream.

#include <cstddef>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codec {

enum class JpegSplitErrc {
  NotAligned, ///< tile edges are not on iMCU boundaries (or 12-bit, CMYK): decode and encode
  Invalid,    ///< the JPEG is damaged: wrong size, does not decode, any warning (corrupt data)
};

struct JpegSplitError {
  JpegSplitErrc code = JpegSplitErrc::Invalid;
  std::string message;
};

/** Whether tiles of tileWidth x tileHeight can be cut in the DCT domain from a JPEG whose iMCU is
 * mcuWidth x mcuHeight pixels (16 x 16 for 4:2:0, 8 x 8 for 4:4:4 and grey). */
constexpr bool jpegTilesAligned(int tileWidth, int tileHeight, int mcuWidth, int mcuHeight) {
  return mcuWidth > 0 && mcuHeight > 0 && tileWidth % mcuWidth == 0 && tileHeight % mcuHeight == 0;
}

/**
 * Splits a JPEG of exactly cols * tileWidth x rows * tileHeight pixels (grey or YCbCr, 8-bit,
 * baseline or progressive) into its cols x rows tiles, row-major from the top-left. Reading the
 * coefficients decodes every entropy-coded block, so this is also the JPEG's validation: any
 * libjpeg warning (corrupt or truncated data) fails with Invalid and gives no tile. The tiles are
 * baseline JPEGs with the standard Huffman tables, or optimal ones with `optimizeHuffman` (a
 * little smaller, an extra pass over each tile's blocks).
 */
std::expected<std::vector<std::vector<std::byte>>, JpegSplitError>
splitJpegDct(std::span<const std::byte> jpeg,
             int cols,
             int rows,
             int tileWidth,
             int tileHeight,
             bool optimizeHuffman = false);

} // namespace tellus::codec
