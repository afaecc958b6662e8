#include "TextOverlay.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstddef>

namespace tellus::planet {

namespace {

struct Glyph {
  char c;
  std::array<const char*, 7> rows; // '#' = ink, top row first
};

// Drawn for this project: plain 5 x 7 shapes.
constexpr std::array kGlyphs{
    Glyph{'0', {" ### ", "#   #", "#  ##", "# # #", "##  #", "#   #", " ### "}},
    Glyph{'1', {"  #  ", " ##  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "}},
    Glyph{'2', {" ### ", "#   #", "    #", "   # ", "  #  ", " #   ", "#####"}},
    Glyph{'3', {"#####", "   # ", "  #  ", "   # ", "    #", "#   #", " ### "}},
    Glyph{'4', {"   # ", "  ## ", " # # ", "#  # ", "#####", "   # ", "   # "}},
    Glyph{'5', {"#####", "#    ", "#### ", "    #", "    #", "#   #", " ### "}},
    Glyph{'6', {"  ## ", " #   ", "#    ", "#### ", "#   #", "#   #", " ### "}},
    Glyph{'7', {"#####", "    #", "   # ", "  #  ", " #   ", " #   ", " #   "}},
    Glyph{'8', {" ### ", "#   #", "#   #", " ### ", "#   #", "#   #", " ### "}},
    Glyph{'9', {" ### ", "#   #", "#   #", " ####", "    #", "   # ", " ##  "}},
    Glyph{'A', {" ### ", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"}},
    Glyph{'B', {"#### ", "#   #", "#   #", "#### ", "#   #", "#   #", "#### "}},
    Glyph{'C', {" ### ", "#   #", "#    ", "#    ", "#    ", "#   #", " ### "}},
    Glyph{'D', {"###  ", "#  # ", "#   #", "#   #", "#   #", "#  # ", "###  "}},
    Glyph{'E', {"#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#####"}},
    Glyph{'F', {"#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#    "}},
    Glyph{'G', {" ### ", "#   #", "#    ", "# ###", "#   #", "#   #", " ####"}},
    Glyph{'H', {"#   #", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"}},
    Glyph{'I', {" ### ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "}},
    Glyph{'J', {"  ###", "   # ", "   # ", "   # ", "   # ", "#  # ", " ##  "}},
    Glyph{'K', {"#   #", "#  # ", "# #  ", "##   ", "# #  ", "#  # ", "#   #"}},
    Glyph{'L', {"#    ", "#    ", "#    ", "#    ", "#    ", "#    ", "#####"}},
    Glyph{'M', {"#   #", "## ##", "# # #", "# # #", "#   #", "#   #", "#   #"}},
    Glyph{'N', {"#   #", "#   #", "##  #", "# # #", "#  ##", "#   #", "#   #"}},
    Glyph{'O', {" ### ", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "}},
    Glyph{'P', {"#### ", "#   #", "#   #", "#### ", "#    ", "#    ", "#    "}},
    Glyph{'Q', {" ### ", "#   #", "#   #", "#   #", "# # #", "#  # ", " ## #"}},
    Glyph{'R', {"#### ", "#   #", "#   #", "#### ", "# #  ", "#  # ", "#   #"}},
    Glyph{'S', {" ####", "#    ", "#    ", " ### ", "    #", "    #", "#### "}},
    Glyph{'T', {"#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  "}},
    Glyph{'U', {"#   #", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "}},
    Glyph{'V', {"#   #", "#   #", "#   #", "#   #", "#   #", " # # ", "  #  "}},
    Glyph{'W', {"#   #", "#   #", "#   #", "# # #", "# # #", "# # #", " # # "}},
    Glyph{'X', {"#   #", "#   #", " # # ", "  #  ", " # # ", "#   #", "#   #"}},
    Glyph{'Y', {"#   #", "#   #", " # # ", "  #  ", "  #  ", "  #  ", "  #  "}},
    Glyph{'Z', {"#####", "    #", "   # ", "  #  ", " #   ", "#    ", "#####"}},
    Glyph{'.', {"     ", "     ", "     ", "     ", "     ", " ##  ", " ##  "}},
    Glyph{',', {"     ", "     ", "     ", "     ", " ##  ", "  #  ", " #   "}},
    Glyph{'-', {"     ", "     ", "     ", "#####", "     ", "     ", "     "}},
    Glyph{':', {"     ", " ##  ", " ##  ", "     ", " ##  ", " ##  ", "     "}},
    Glyph{'/', {"    #", "    #", "   # ", "  #  ", " #   ", "#    ", "#    "}},
    Glyph{'%', {"##   ", "##  #", "   # ", "  #  ", " #   ", "#  ##", "   ##"}},
    Glyph{'(', {"   # ", "  #  ", " #   ", " #   ", " #   ", "  #  ", "   # "}},
    Glyph{')', {" #   ", "  #  ", "   # ", "   # ", "   # ", "  #  ", " #   "}},
};

const Glyph* find(char c) noexcept {
  const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kGlyphs)
    if (g.c == u) return &g;
  return nullptr;
}

} // namespace

bool hasGlyph(char c) noexcept {
  return find(c) != nullptr;
}

TextImage rasterizeText(std::string_view text, int scale) {
  scale = std::clamp(scale, 1, 8);
  const int cellW = 6 * scale, cellH = 9 * scale, margin = 2 * scale;
  TextImage img;
  img.width = static_cast<int>(text.size()) * cellW + 2 * margin;
  img.height = cellH + 2 * margin;
  img.rgba.assign(static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height) * 4,
                  0);
  for (std::size_t i = 3; i < img.rgba.size(); i += 4)
    img.rgba[i] = 255; // an opaque dark strip: the text stays readable over bright ground
  for (std::size_t i = 0; i < img.rgba.size(); i += 4)
    img.rgba[i] = img.rgba[i + 1] = img.rgba[i + 2] = 24;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const Glyph* g = find(text[k]);
    if (g == nullptr) continue;
    for (int row = 0; row < 7; ++row)
      for (int col = 0; col < 5; ++col) {
        if (g->rows[static_cast<std::size_t>(row)][col] != '#') continue;
        for (int sy = 0; sy < scale; ++sy)
          for (int sx = 0; sx < scale; ++sx) {
            const int x = margin + static_cast<int>(k) * cellW + col * scale + sx;
            const int yTop = margin + scale + row * scale + sy; // one spacing row above
            const int y = img.height - 1 - yTop;                // rows from the bottom
            const std::size_t at =
                (static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width) +
                 static_cast<std::size_t>(x)) *
                4;
            img.rgba[at] = img.rgba[at + 1] = img.rgba[at + 2] = 240;
          }
      }
  }
  return img;
}

} // namespace tellus::planet
