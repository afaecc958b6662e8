#pragma once
/**
 * @file Bil16.hpp
 * @brief BIL16 ("application/bil16", World Wind's elevation tiles): signed 16-bit samples,
 * little-endian whatever the host, row-major from the top (north), no header.
 */

#include <tellus/codec/Image.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codec {

/** The width * height samples of exactly width * height * 2 bytes (a width or height of 0 is an
 * empty tile; a negative one is an error); else "the bil16 tile has N bytes, not M". */
std::expected<std::vector<std::int16_t>, std::string>
decodeBil16(std::span<const std::byte> bytes, int width, int height);

/** width * height samples (`heights`) as bytes; empty when the shape is negative. */
Bytes encodeBil16(int width, int height, const std::int16_t* heights);

} // namespace tellus::codec
