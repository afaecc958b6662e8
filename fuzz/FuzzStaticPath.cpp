// libFuzzer target: the paths of the static tile front end and of the cache's tile tree
// (parseStaticTilePath, parseTileRelativePath) and the encoding of names into one path component
// (encodeNameComponent), and WMTS's RESTful paths (parseWmtsRest). A path that parses must be the
// canonical text of what it parsed to (no two paths name one tile); an encoded name must be one
// harmless path component.

#include "FuzzCheck.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/cache/TileSource.hpp>
#include <tellus/proxy/Wms.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace {

using namespace tellus;

bool isLayerChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '.' || c == '-';
}

bool isAlnum(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
}

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1; // encodeNameComponent writes lower-case hex only
}

// Inverse of encodeNameComponent for names that were not cut: every '%' starts two hex digits.
std::optional<std::string> decodeComponent(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '%') {
      out.push_back(s[i]);
      continue;
    }
    if (i + 2 >= s.size()) return std::nullopt;
    const int hi = hexValue(s[i + 1]);
    const int lo = hexValue(s[i + 2]);
    if (hi < 0 || lo < 0) return std::nullopt;
    out.push_back(static_cast<char>(hi * 16 + lo));
    i += 2;
  }
  return out;
}

void checkEncodedName(std::string_view name) {
  const std::string enc = encodeNameComponent(name);
  TELLUS_FUZZ_CHECK(!enc.empty() && enc.size() <= kMaxNameComponent);
  TELLUS_FUZZ_CHECK(enc.find('/') == std::string::npos);
  TELLUS_FUZZ_CHECK(enc.find('\\') == std::string::npos);
  TELLUS_FUZZ_CHECK(enc.find('\0') == std::string::npos);
  TELLUS_FUZZ_CHECK(enc.front() != '.');
  TELLUS_FUZZ_CHECK(enc != "." && enc != "..");
  for (const char c : enc)
    TELLUS_FUZZ_CHECK(isLayerChar(c) || c == '%' || c == '~');
  if (name.empty()) {
    TELLUS_FUZZ_CHECK(enc == "%");
    return;
  }
  // Short names are encoded reversibly (hence distinct names stay distinct).
  if (name.size() <= kMaxNameComponent / 3) {
    const auto back = decodeComponent(enc);
    TELLUS_FUZZ_CHECK(back && *back == name);
  }
  // Stable: the same name always gives the same folder.
  TELLUS_FUZZ_CHECK(encodeNameComponent(name) == enc);
}

void checkRelativePath(std::string_view path) {
  std::string ext;
  const auto key = parseTileRelativePath(path, &ext);
  if (!key) return;
  TELLUS_FUZZ_CHECK(key->level >= 0 && key->level <= kMaxLevel);
  TELLUS_FUZZ_CHECK(key->row >= 0 && key->col >= 0);
  TELLUS_FUZZ_CHECK(!ext.empty() && ext.find('/') == std::string::npos);
  // The documented format has no padding and no signs: a path that parses is canonical.
  TELLUS_FUZZ_CHECK(tileRelativePath(*key, ext) == path);
  const auto again = parseTileRelativePath(tileRelativePath(*key, ext), nullptr);
  TELLUS_FUZZ_CHECK(again && *again == *key);
}

void checkStaticPath(std::string_view path) {
  const auto p = parseStaticTilePath(path);
  if (!p) return;
  // The layer, or its whole rows or spans (`<layer>@caps`, `<layer>@span<k>`, issue 29).
  const std::string_view layer = wholeBoxLayer(p->layer).value_or(p->layer);
  if (const auto span = parseWholeSpanLayer(p->layer))
    TELLUS_FUZZ_CHECK(wholeSpanLayer(span->layer, span->span) == p->layer); // canonical
  TELLUS_FUZZ_CHECK(!layer.empty() && layer.size() <= kMaxStaticLayerName);
  TELLUS_FUZZ_CHECK(layer != "." && layer != "..");
  for (const char c : layer)
    TELLUS_FUZZ_CHECK(isLayerChar(c));
  TELLUS_FUZZ_CHECK(!p->extension.empty() && p->extension.size() <= 16);
  for (const char c : p->extension)
    TELLUS_FUZZ_CHECK(isAlnum(c));
  TELLUS_FUZZ_CHECK(p->key.level >= 0 && p->key.level <= kMaxLevel);
  TELLUS_FUZZ_CHECK(p->key.row >= 0 && p->key.col >= 0);
  TELLUS_FUZZ_CHECK(p->layer + "/" + tileRelativePath(p->key, p->extension) == path);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  checkStaticPath(input);
  checkRelativePath(input);
  // Also the path below the layer, as the cache meets it inside a dataset folder.
  if (const auto slash = input.find('/'); slash != std::string_view::npos) {
    checkRelativePath(input.substr(slash + 1));
  }
  checkEncodedName(input);
  // A WMTS RESTful path: a tile has every part, whole numbers, an extension; an error says why.
  if (const auto wmts = parseWmtsRest(input)) {
    if (const auto* t = std::get_if<WmtsGetTileRequest>(&*wmts)) {
      TELLUS_FUZZ_CHECK(!t->layer.empty() && !t->style.empty() && !t->tileMatrixSet.empty() &&
                        !t->tileMatrix.empty() && !t->extension.empty());
      TELLUS_FUZZ_CHECK(t->row >= 0 && t->col >= 0 && (!t->time || !t->time->empty()));
    }
  } else {
    TELLUS_FUZZ_CHECK(!wmts.error().message.empty());
  }
  return 0;
}
