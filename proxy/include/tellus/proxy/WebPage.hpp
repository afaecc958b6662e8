#pragma once
/**
 * @file WebPage.hpp
 * @brief The page at `/` of `tellus serve`: a map of the server's layers (OpenLayers, bundled from
 * proxy/web/ by esbuild at build time and embedded in the binary, so it needs no files on disk and
 * loads nothing from the internet), its `/layers.json`, and the plain-text index at `/index.txt`.
 *
 * Paths: `/` (index.html), `/app.js`, `/app.css`, `/licenses.txt` (the bundled packages' licences),
 * `/layers.json`, `/index.txt`. The page fetches everything with relative URLs, tiles from the
 * static World Wind layout `tiles/<layer>/<level>/<row>/<row>_<col>.<ext>`.
 */

#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/TileService.hpp>

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace tellus {

/** True for the paths of the page (see the file comment); the front end routes them as `Page`. */
bool isWebPagePath(std::string_view path) noexcept;

/** True when the page was built into this binary (CMake option TELLUS_WEB_PAGE); without it, `/`
 * serves the plain-text index. */
bool webPageEmbedded() noexcept;

/**
 * The embedded file at `path` (`/` is index.html) as an answer: its Content-Type, a strong ETag,
 * Cache-Control (index.html is revalidated every time; the bundle, which index.html names with its
 * content hash, is kept a day), gzip-compressed when Accept-Encoding allows it (Vary), 304 when
 * If-None-Match holds the ETag. std::nullopt when no such file is embedded.
 */
std::optional<HttpResponse> webAssetResponse(const HttpRequest& request);

/** Whether a layer's whole polar rows and spans are served (TileService::wholePolarRows). */
using WholeRowsOf = std::function<bool(const LayerSpec&)>;

/**
 * `/layers.json`: the title and, per layer, what the page needs to draw its tiles: name, title,
 * format, extension, elevation, levelZeroDelta (degrees), tileWidth/tileHeight (pixels), levels,
 * firstLevel and the sector; and `"wholeRows":true` for a layer whose `/tiles/<layer>@caps/...`
 * and `/tiles/<layer>@span<k>/...` are served (issue 29; absent: not). Strings are JSON-escaped
 * (any byte is safe).
 */
std::string layersJson(std::string_view title,
                       std::span<const LayerSpec> layers,
                       const WholeRowsOf& whole = {});

/** `layersJson` as an answer: application/json, ETag of the body, revalidated every time. */
HttpResponse layersJsonResponse(const HttpRequest& request,
                                std::string_view title,
                                std::span<const LayerSpec> layers,
                                const WholeRowsOf& whole = {});

} // namespace tellus
