#pragma once
// The renderer's side of the codec module (tellus::codec): JPEG and PNG bytes into RGBA8 for node
// textures and image files, and PNG writing. No libjpeg or libpng here: the codec module has them.

#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <span>
#include <string>

namespace tellus::planet {

/** Whether the bytes start like a JPEG or a PNG (what decodeJpegOrPng reads). */
bool isJpegOrPng(std::span<const std::byte> bytes) noexcept;

/** Decodes JPEG or PNG bytes (by their magic) into RGBA8 rows from the top. */
std::expected<RgbaImage, std::string> decodeJpegOrPng(std::span<const std::byte> bytes);

} // namespace tellus::planet
