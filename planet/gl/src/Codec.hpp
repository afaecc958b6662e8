#pragma once
// JPEG (libjpeg-turbo) and PNG (libpng) decoding into RGBA8 for node textures, and PNG writing.

#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace tellus::planet::codec {

/** Whether the bytes start like a JPEG or a PNG (what decode reads). */
bool isJpegOrPng(std::span<const std::byte> bytes) noexcept;

/** Decodes JPEG or PNG bytes (by their magic) into RGBA8 rows from the top. */
std::expected<RgbaImage, std::string> decode(std::span<const std::byte> bytes);

} // namespace tellus::planet::codec
