#pragma once
/**
 * @file TileValidation.hpp
 * @brief "Is this really a tile": upstreams answer errors as XML or HTML with status 200 and an
 * image content type, or send truncated or wrongly sized images. Nothing that fails here may be
 * cached or served as a tile.
 */

#include <tellus/proxy/Fetcher.hpp>

#include <cstddef>
#include <expected>
#include <span>
#include <string>
#include <string_view>

namespace tellus {

enum class ImageKind { Jpeg, Png, Tiff, Gif, Webp, Xml, Html, Unknown };

const char* toString(ImageKind kind) noexcept;

/** What the bytes are, from their magic numbers. XML and HTML may start with a byte-order mark and
 * whitespace; a document whose first element is `<html` (or `<!DOCTYPE html`) is Html. */
ImageKind sniff(std::span<const std::byte> bytes) noexcept;

/**
 * Checks that an upstream response is a usable tile:
 * - status 200 and a non-empty body;
 * - not an XML/HTML body (whatever the content type); a ServiceException's text is returned,
 *   shortened to 200 characters with URLs removed;
 * - the content type matches `expectedMime` (parameters ignored; for application/bil16 also
 *   application/bil, image/bil and application/octet-stream) and the bytes are that format;
 * - JPEG, PNG and TIFF decode completely at expectedWidth x expectedHeight;
 * - application/bil16 is exactly width * height * 2 bytes.
 * The error says what is wrong, for logs (never an upstream URL).
 */
std::expected<void, std::string> validateTile(const FetchResponse& response,
                                              std::string_view expectedMime,
                                              int expectedWidth,
                                              int expectedHeight);

/** validateTile without the decoding and the size: status, body, markup, content type, magic
 * bytes, a JPEG's end-of-image marker. What the bytes are, for a caller that decodes them itself
 * (a metatile is decoded once when it is split). */
std::expected<ImageKind, std::string> validateImageResponse(const FetchResponse& response,
                                                            std::string_view expectedMime);

/** The readable text of an OGC ServiceException (or OWS ExceptionText) in an XML body, sanitised
 * as validateTile does; empty when there is none. */
std::string serviceExceptionText(std::span<const std::byte> body);

} // namespace tellus
