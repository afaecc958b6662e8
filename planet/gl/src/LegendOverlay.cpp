#include "LegendOverlay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace tellus::planet {

int legendScaleFactor(int width, int height) noexcept {
  const int side = std::min(width, height);
  return std::clamp(static_cast<int>(std::lround(side / 1024.0)), 1, 16);
}

std::vector<LegendRect> legendPlacement(
    int width, int height, bool dome, int legendWidth, int legendHeight, int margin, int count) {
  std::vector<LegendRect> out;
  if (!dome) {
    for (int i = 0; i < count; ++i) {
      const LegendRect r{margin, margin + i * (legendHeight + margin), legendWidth, legendHeight};
      if (r.x + r.width > width || r.y + r.height > height) break;
      out.push_back(r);
    }
    return out;
  }
  const double d = std::min(width, height), radius = 0.5 * d;
  const double cx = 0.5 * width, cy = 0.5 * height;
  const double half = 0.5 * legendWidth;
  if (!(half < radius)) return out;
  // The lowest bottom edge whose two lower corners lie inside the circle, then a margin.
  double y = cy - std::sqrt(radius * radius - half * half) + margin;
  for (int i = 0; i < count; ++i) {
    const double top = y + legendHeight;
    // Both upper corners inside too (the legend is below the centre, or is it past it?).
    if (std::hypot(half, top - cy) > radius || std::hypot(half, y - cy) > radius) break;
    out.push_back({static_cast<int>(std::ceil(cx - half)),
                   static_cast<int>(std::ceil(y)),
                   legendWidth,
                   legendHeight});
    y = top + margin;
  }
  return out;
}

std::expected<codec::Image, std::string> legendImage(const LegendEntry& entry, int scaleFactor) {
  values::LegendOptions o;
  o.width = kLegendWidth;
  o.height = kLegendHeight;
  o.scaleFactor = scaleFactor;
  o.background = {16, 16, 16, 255}; // opaque: copied as it is, over any globe
  o.foreground = {255, 255, 255, 255};
  return values::renderLegend(entry.scale, entry.unit, entry.title, o);
}

namespace {

std::string keyOf(const LegendEntry& e, int factor) {
  char buf[160];
  std::snprintf(buf,
                sizeof buf,
                "%.17g %.17g %d %d %d|",
                e.scale.min,
                e.scale.max,
                static_cast<int>(e.scale.scaling),
                static_cast<int>(e.scale.outOfRange),
                factor);
  return std::string(buf) + std::string(e.scale.map->name) + "|" + e.unit + "|" + e.title;
}

} // namespace

void LegendOverlay::draw(
    const std::vector<LegendEntry>& entries, GLuint fbo, int width, int height, bool dome) {
  const int factor = legendScaleFactor(width, height);
  made_.resize(entries.size());
  const auto rects = legendPlacement(width,
                                     height,
                                     dome,
                                     kLegendWidth * factor,
                                     kLegendHeight * factor,
                                     kLegendMargin * factor,
                                     static_cast<int>(entries.size()));
  for (std::size_t i = 0; i < rects.size(); ++i) {
    Made& m = made_[i];
    const std::string key = keyOf(entries[i], factor);
    if (key != m.key) {
      auto img = legendImage(entries[i], factor);
      if (!img) continue;
      // Rows from the bottom, as GL's.
      std::vector<std::uint8_t> flipped(img->pixels.size());
      const auto stride = static_cast<std::size_t>(img->width) * 4;
      for (int y = 0; y < img->height; ++y)
        std::copy_n(img->pixels.data() + static_cast<std::size_t>(y) * stride,
                    stride,
                    flipped.data() + static_cast<std::size_t>(img->height - 1 - y) * stride);
      if (!m.texture.created()) {
        m.texture = GlTexture();
        m.fbo = GlFramebuffer();
      }
      glBindTexture(GL_TEXTURE_2D, m.texture.id());
      glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
      glTexImage2D(GL_TEXTURE_2D,
                   0,
                   GL_RGBA8,
                   img->width,
                   img->height,
                   0,
                   GL_RGBA,
                   GL_UNSIGNED_BYTE,
                   flipped.data());
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
      glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo.id());
      glFramebufferTexture2D(
          GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, m.texture.id(), 0);
      m.width = img->width;
      m.height = img->height;
      m.key = key;
    }
    const LegendRect& r = rects[i];
    glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo.id());
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo);
    glBlitFramebuffer(0,
                      0,
                      m.width,
                      m.height,
                      r.x,
                      r.y,
                      r.x + m.width,
                      r.y + m.height,
                      GL_COLOR_BUFFER_BIT,
                      GL_NEAREST);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
}

} // namespace tellus::planet
