#include "LegendText.hpp"

#include "Font6x13.hpp"

#include <tellus/values/Legend.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace tellus::values {

namespace detail {

std::u32string decodeUtf8(std::string_view text) {
  std::u32string out;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    const int extra = c < 0x80         ? 0
                      : (c >> 5) == 6  ? 1
                      : (c >> 4) == 14 ? 2
                      : (c >> 3) == 30 ? 3
                                       : -1;
    if (extra < 0 || i + static_cast<std::size_t>(extra) >= text.size()) {
      out.push_back(0xFFFD);
      ++i;
      continue;
    }
    char32_t cp = extra == 0 ? c : c & (0x3Fu >> extra);
    bool ok = true;
    for (int k = 1; k <= extra; ++k) {
      const auto next = static_cast<unsigned char>(text[i + static_cast<std::size_t>(k)]);
      ok = ok && (next & 0xC0) == 0x80;
      cp = (cp << 6) | (next & 0x3Fu);
    }
    out.push_back(ok ? cp : 0xFFFD);
    i += ok ? static_cast<std::size_t>(extra) + 1 : 1;
  }
  return out;
}

namespace {

const Glyph& glyphFor(char32_t cp) {
  for (const Glyph& g : kGlyphs)
    if (g.codePoint == cp) return g;
  return glyphFor(U'?');
}

} // namespace

void drawText(codec::Image& image, int x, int y, std::string_view text, const Rgba8& colour) {
  for (const char32_t cp : decodeUtf8(text)) {
    const Glyph& g = glyphFor(cp);
    for (int row = 0; row < kGlyphHeight; ++row)
      for (int col = 0; col < kGlyphWidth; ++col) {
        if (((g.rows[static_cast<std::size_t>(row)] >> (7 - col)) & 1) == 0) continue;
        const int px = x + col, py = y + row;
        if (px < 0 || py < 0 || px >= image.width || py >= image.height) continue;
        const auto at = (static_cast<std::size_t>(py) * static_cast<std::size_t>(image.width) +
                         static_cast<std::size_t>(px)) *
                        4;
        std::copy(
            colour.begin(), colour.end(), image.pixels.begin() + static_cast<std::ptrdiff_t>(at));
      }
    x += kGlyphWidth;
  }
}

std::string fitText(std::string_view text, int maxWidth) {
  std::string out;
  int width = 0;
  for (std::size_t i = 0; i < text.size();) {
    std::size_t n = 1;
    while (i + n < text.size() && (static_cast<unsigned char>(text[i + n]) & 0xC0) == 0x80)
      ++n;
    if (width + kGlyphWidth > maxWidth) break;
    out.append(text.substr(i, n));
    width += kGlyphWidth;
    i += n;
  }
  return out;
}

} // namespace detail

int legendTextWidth(std::string_view text) noexcept {
  int n = 0;
  for (const char c : text)
    if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) ++n;
  return n * detail::kGlyphWidth;
}

namespace {

std::string trimZeros(std::string s) {
  if (s.find('.') == std::string::npos) return s;
  while (s.back() == '0')
    s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

std::string scientific(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2e", value);
  std::string s(buffer);
  const auto e = s.find('e');
  std::string mantissa = trimZeros(s.substr(0, e));
  int exponent = std::stoi(s.substr(e + 1));
  return mantissa + "e" + std::to_string(exponent);
}

} // namespace

std::string formatTickLabel(double value, double step) {
  const double magnitude = std::fabs(value);
  if (value == 0.0 || (step > 0.0 && magnitude < step * 1e-9)) return "0";
  if (magnitude >= 1e6 || magnitude < 1e-3) return scientific(value);
  int decimals = 0;
  if (step > 0.0)
    decimals = std::clamp(static_cast<int>(std::ceil(-std::log10(step) - 1e-9)), 0, 9);
  else
    decimals = std::clamp(2 - static_cast<int>(std::floor(std::log10(magnitude))), 0, 9);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  std::string s = trimZeros(buffer);
  if (s == "-0") s = "0";
  return s;
}

} // namespace tellus::values
