#pragma once
// What a shared HTTP cache in front of tellus (a CDN, Varnish: docs/design/cdn.md) is told about
// each answer: how long it may keep it (Cache-Control max-age for browsers, s-maxage for shared
// caches), how long past that it may serve it while it asks again or while tellus fails
// (stale-while-revalidate, stale-if-error), which surrogate keys name it for a purge (the `xkey`
// header of Varnish's vmod_xkey) and, for every error, that it is not to be kept at all.
// Pure functions of the configuration: the front ends (proxy/src/frontend/) call them, and
// `tellus cache prune` and `tellus seed --refresh` name the same keys when they purge
// (CdnPurge.hpp).

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** YAML `server.cdn` (docs/CONFIG.md). Durations in whole seconds. */
struct CdnOptions {
  /// s-maxage: how long a shared cache keeps a tile; nullopt: the layer's `ttl` when it has one
  /// (tellus would revalidate the tile then), else its `max_age`.
  std::optional<std::chrono::seconds> sMaxAge;
  /// stale-while-revalidate; nullopt: s-maxage, at most a day.
  std::optional<std::chrono::seconds> staleWhileRevalidate;
  /// stale-if-error: a shared cache may ride out tellus's own failures this long.
  std::chrono::seconds staleIfError{7 * 86400};
  /// The lifetime of an answer that says "no tile here" (404, an empty WMS map) or a stale tile
  /// served because the upstream failed: short, so that the tile shows once it exists.
  std::chrono::seconds shortMaxAge{60};
  /// The surrogate-key header on every cacheable answer; "" = none.
  std::string keyHeader = "xkey";
  /// Where `tellus cache prune` and `tellus seed --refresh` send `PURGE` with the keys they
  /// removed (an `xkey-purge` header); empty: no purge.
  std::vector<std::string> purge;
};

/** The header value of an answer no cache may keep: every error (OGC exceptions, 4xx but an
 * absent tile's 404, 5xx, 429). */
inline constexpr std::string_view kNoStore = "no-store";

/** Cache-Control of a tile or map kept for `maxAge` by browsers, its shared-cache lifetime from
 * the layer's `ttl` (0: tiles never expire) unless configured. */
std::string
tileCacheControl(std::chrono::seconds maxAge, std::chrono::milliseconds ttl, const CdnOptions& cdn);

/** Cache-Control of an absent tile, an empty map or a stale tile: shortMaxAge for both. */
std::string shortCacheControl(const CdnOptions& cdn);

/** Whether a response with this status and Cache-Control may be kept by a cache as it is; false:
 * it must say no-store (finishCaching). An error is never kept; a 404 only when its front end gave
 * it a lifetime (an absent tile). */
bool keepable(int status, std::string_view cacheControl);

/** Surrogate keys (docs/design/cdn.md), space-separated:
 *   `tellus`                 everything tellus answered
 *   `layer:<name>`           every answer of a layer (tiles, composed maps, its legend)
 *   `layer:<name>@<time>`    one time of a layer with a TIME dimension (time non-empty)
 *   `layer:<name>/<level>`   one level of the layer's own grid (level >= 0)
 * Layer names are [A-Za-z0-9_.-]; a time's blanks and commas (never valid) become '_'. */
std::string layerKeys(std::string_view layer, std::string_view time, std::int32_t level = -1);
/** The keys of one layer (and time) without `tellus`: what a purge of it names. */
std::string layerKey(std::string_view layer, std::string_view time = {});
/** The capabilities documents' keys: `tellus capabilities`. */
std::string capabilitiesKeys();

} // namespace tellus
