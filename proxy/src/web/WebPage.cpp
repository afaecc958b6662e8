#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/HttpDates.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <initializer_list>
#include <utility>

// The page's files, built by proxy/web/build.mjs into TELLUS_WEB_DIST (proxy/CMakeLists.txt) and
// assembled into this object with .incbin: `tellus serve` needs no files on disk. Each file has a
// start and an end symbol, and a gzip-compressed twin (<name>_gz). The object is recompiled when a
// file changes (OBJECT_DEPENDS in proxy/CMakeLists.txt).
#if TELLUS_WEB_PAGE
#define TELLUS_WEB_INCBIN(sym, file)                                                               \
  asm(".pushsection .rodata.tellus_web, \"a\"\n"                                                   \
      ".balign 16\n"                                                                               \
      ".globl " #sym "\n"                                                                          \
      ".hidden " #sym "\n" #sym ":\n"                                                              \
      ".incbin \"" TELLUS_WEB_DIST "/" file "\"\n"                                                 \
      ".globl " #sym "_end\n"                                                                      \
      ".hidden " #sym "_end\n" #sym "_end:\n"                                                      \
      ".byte 0\n"                                                                                  \
      ".popsection\n");                                                                            \
  extern "C" const char sym[];                                                                     \
  extern "C" const char sym##_end[];

TELLUS_WEB_INCBIN(tellus_web_index_html, "index.html")
TELLUS_WEB_INCBIN(tellus_web_index_html_gz, "index.html.gz")
TELLUS_WEB_INCBIN(tellus_web_app_js, "app.js")
TELLUS_WEB_INCBIN(tellus_web_app_js_gz, "app.js.gz")
TELLUS_WEB_INCBIN(tellus_web_app_css, "app.css")
TELLUS_WEB_INCBIN(tellus_web_app_css_gz, "app.css.gz")
TELLUS_WEB_INCBIN(tellus_web_licenses_txt, "licenses.txt")
TELLUS_WEB_INCBIN(tellus_web_licenses_txt_gz, "licenses.txt.gz")
#endif

namespace tellus {
namespace {

struct Representation {
  std::string_view bytes;
  std::string etag; ///< strong, quoted, of these bytes
};

struct Asset {
  std::string_view path;
  std::string_view contentType;
  std::string_view cacheControl;
  Representation identity;
  Representation gzip;
};

std::string quotedHash(std::string_view bytes) {
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(bytes)));
  return etag;
}

[[maybe_unused]] Representation representation(const char* begin, const char* end) {
  const std::string_view bytes(begin, static_cast<std::size_t>(end - begin));
  return {bytes, quotedHash(bytes)};
}

// index.html names app.js and app.css with their content hash (?v=...), so those may be kept.
constexpr std::string_view kRevalidate = "no-cache";
[[maybe_unused]] constexpr std::string_view kKeepADay = "public, max-age=86400";

/** The embedded files, hashed once (thread-safe static initialisation). */
const std::vector<Asset>& assets() {
  static const std::vector<Asset> all = [] {
    std::vector<Asset> a;
#if TELLUS_WEB_PAGE
#define TELLUS_WEB_ASSET(path, type, cache, sym)                                                   \
  a.push_back(Asset{                                                                               \
      path, type, cache, representation(sym, sym##_end), representation(sym##_gz, sym##_gz_end)});
    TELLUS_WEB_ASSET("/", "text/html; charset=utf-8", kRevalidate, tellus_web_index_html)
    TELLUS_WEB_ASSET("/app.js", "text/javascript; charset=utf-8", kKeepADay, tellus_web_app_js)
    TELLUS_WEB_ASSET("/app.css", "text/css; charset=utf-8", kKeepADay, tellus_web_app_css)
    TELLUS_WEB_ASSET(
        "/licenses.txt", "text/plain; charset=utf-8", kKeepADay, tellus_web_licenses_txt)
#undef TELLUS_WEB_ASSET
#endif
    return a;
  }();
  return all;
}

/** Accept-Encoding names gzip (or *) with a non-zero quality. */
bool acceptsGzip(std::string_view header) {
  std::size_t pos = 0;
  while (pos < header.size()) {
    const auto comma = header.find(',', pos);
    std::string_view item =
        header.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
    pos = comma == std::string_view::npos ? header.size() : comma + 1;
    std::string_view coding = item.substr(0, item.find(';'));
    while (!coding.empty() && (coding.front() == ' ' || coding.front() == '\t'))
      coding.remove_prefix(1);
    while (!coding.empty() && (coding.back() == ' ' || coding.back() == '\t'))
      coding.remove_suffix(1);
    std::string lower(coding);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](char c) {
      return static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    });
    if (lower != "gzip" && lower != "x-gzip" && lower != "*") continue;
    // "q=0", "q=0.0", "q=0.000": refused; anything else accepted.
    const auto q = item.find("q=");
    if (q == std::string_view::npos) return true;
    const std::string_view value = item.substr(q + 2);
    const bool zero = !value.empty() && value.front() == '0' &&
                      value.substr(1).find_first_not_of(".0 \t") == std::string_view::npos;
    if (!zero) return true;
  }
  return false;
}

HttpResponse answer(const HttpRequest& request,
                    std::string_view contentType,
                    std::string_view cacheControl,
                    const Representation& body,
                    bool gzip) {
  HttpResponse r;
  r.setHeader("Content-Type", std::string(contentType));
  r.setHeader("Cache-Control", std::string(cacheControl));
  r.setHeader("ETag", body.etag);
  r.setHeader("Vary", "Accept-Encoding");
  if (gzip) r.setHeader("Content-Encoding", "gzip");
  if (ifNoneMatchHits(request.header("if-none-match"), body.etag)) {
    r.status = 304;
    return r;
  }
  r.status = 200;
  r.body.resize(body.bytes.size());
  std::transform(body.bytes.begin(), body.bytes.end(), r.body.begin(), [](char c) {
    return static_cast<std::byte>(c);
  });
  return r;
}

/** A JSON string, escaped by nlohmann-json; invalid UTF-8 replaced (U+FFFD), not thrown at. */
std::string jsonString(std::string_view s) {
  return nlohmann::json(std::string(s))
      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

/** Shortest round-trip (std::to_chars): "36", "22.5", "5e-04", as /layers.json has always had them
 * (nlohmann-json writes "36.0", "0.0005" and, for some doubles, 17 digits where 16 do). */
std::string jsonNumber(double v) {
  std::array<char, 32> buf{};
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), ec == std::errc() ? end : buf.data());
}

/** {"key":value,...} without spaces; the values are JSON already. */
std::string jsonObject(std::initializer_list<std::pair<std::string_view, std::string>> members) {
  std::string out = "{";
  for (const auto& [key, value] : members)
    out += (out.size() > 1 ? "," : "") + jsonString(key) + ":" + value;
  return out + "}";
}

std::string layerJson(const LayerSpec& l, bool wholeRows) {
  const GridSpec& g = l.dataset.grid;
  std::string j = jsonObject({{"name", jsonString(l.name)},
                              {"title", jsonString(l.title.empty() ? l.name : l.title)},
                              {"format", jsonString(l.dataset.mimeType)},
                              {"extension", jsonString(l.dataset.extension)},
                              {"elevation", l.elevation ? "true" : "false"},
                              {"body", jsonString(l.dataset.body)},
                              {"levelZeroDelta", jsonNumber(g.levelZeroDeltaDeg)},
                              {"tileWidth", std::to_string(g.tileWidth)},
                              {"tileHeight", std::to_string(g.tileHeight)},
                              {"levels", std::to_string(g.numLevels)},
                              {"firstLevel", std::to_string(l.firstLevel)},
                              {"sector",
                               jsonObject({{"west", jsonNumber(g.sector.west)},
                                           {"south", jsonNumber(g.sector.south)},
                                           {"east", jsonNumber(g.sector.east)},
                                           {"north", jsonNumber(g.sector.north)}})}});
  if (wholeRows) j.insert(j.size() - 1, ",\"wholeRows\":true");
  return j;
}

} // namespace

bool isWebPagePath(std::string_view path) noexcept {
  return path == "/" || path == "/app.js" || path == "/app.css" || path == "/licenses.txt" ||
         path == "/layers.json" || path == "/index.txt";
}

bool webPageEmbedded() noexcept {
  return TELLUS_WEB_PAGE != 0;
}

std::optional<HttpResponse> webAssetResponse(const HttpRequest& request) {
  for (const Asset& a : assets()) {
    if (a.path != request.path) continue;
    const bool gzip = acceptsGzip(request.header("accept-encoding"));
    return answer(request, a.contentType, a.cacheControl, gzip ? a.gzip : a.identity, gzip);
  }
  return std::nullopt;
}

std::string
layersJson(std::string_view title, std::span<const LayerSpec> layers, const WholeRowsOf& whole) {
  // One layer a line, as the page has always been served (and its ETag computed).
  std::string j = "{\"title\":" + jsonString(title) + ",\"layers\":[";
  for (std::size_t i = 0; i < layers.size(); ++i)
    j += (i == 0 ? "\n" : ",\n") + layerJson(layers[i], whole && whole(layers[i]));
  return j + "\n]}\n";
}

HttpResponse layersJsonResponse(const HttpRequest& request,
                                std::string_view title,
                                std::span<const LayerSpec> layers,
                                const WholeRowsOf& whole) {
  const std::string json = layersJson(title, layers, whole);
  const Representation body{json, quotedHash(json)};
  return answer(request, "application/json", kRevalidate, body, false);
}

} // namespace tellus
