#include <tellus/codec/Png.hpp>
#include <tellus/planet/ChannelWarp.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

namespace tellus::planet {
namespace {

std::unexpected<std::string> fail(std::string_view origin, const std::string& what) {
  return std::unexpected(origin.empty() ? what : std::string(origin) + ": " + what);
}

std::expected<std::string, std::string> slurp(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected(file.string() + ": cannot be read");
  return std::string{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t index(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}

/** Bilinear sample of one channel at (x, y) in pixels (centres at +0.5), clamped. */
double sample(const ChannelImage& im, double x, double y, int k) {
  x = std::clamp(x - 0.5, 0.0, im.width - 1.0);
  y = std::clamp(y - 0.5, 0.0, im.height - 1.0);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, im.width - 1), y1 = std::min(y0 + 1, im.height - 1);
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int px, int py) {
    return static_cast<double>(im.rgba[index(px, py, im.width) * 4 + static_cast<std::size_t>(k)]);
  };
  return (at(x0, y0) * (1 - fx) + at(x1, y0) * fx) * (1 - fy) +
         (at(x0, y1) * (1 - fx) + at(x1, y1) * fx) * fy;
}

} // namespace

WarpMesh WarpMesh::identity(int columns, int rows) {
  WarpMesh m{columns, rows, {}};
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < columns; ++i)
      m.uv.emplace_back(static_cast<double>(i) / (columns - 1),
                        static_cast<double>(j) / (rows - 1));
  return m;
}

std::expected<WarpMesh, std::string> parseWarpMesh(std::string_view json, std::string_view origin) {
  const auto root = nlohmann::json::parse(json, nullptr, false);
  if (root.is_discarded() || !root.is_object()) return fail(origin, "not a JSON object");
  for (const auto& [key, value] : root.items()) {
    (void)value;
    if (key != "columns" && key != "rows" && key != "uv")
      return fail(origin, "unknown key \"" + key + "\"");
  }
  WarpMesh m;
  for (const auto& [key, out] : {std::pair{"columns", &m.columns}, std::pair{"rows", &m.rows}}) {
    const auto it = root.find(key);
    if (it == root.end() || !it->is_number_integer() || it->get<long long>() < 2 ||
        it->get<long long>() > 4096)
      return fail(origin, std::string(key) + ": an integer in [2, 4096] is required");
    *out = it->get<int>();
  }
  const auto uv = root.find("uv");
  const auto n = static_cast<std::size_t>(m.columns) * static_cast<std::size_t>(m.rows);
  if (uv == root.end() || !uv->is_array() || uv->size() != n)
    return fail(origin, "uv: " + std::to_string(n) + " [u, v] pairs (rows x columns) required");
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = (*uv)[i];
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
        !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>()))
      return fail(origin, "uv[" + std::to_string(i) + "]: not a pair of finite numbers");
    m.uv.emplace_back(p[0].get<double>(), p[1].get<double>());
  }
  return m;
}

std::expected<WarpMesh, std::string> readWarpMesh(const std::filesystem::path& file) {
  const auto text = slurp(file);
  if (!text) return std::unexpected(text.error());
  return parseWarpMesh(*text, file.string());
}

std::expected<std::vector<float>, std::string>
readBlendMask(const std::filesystem::path& file, int width, int height) {
  const auto text = slurp(file);
  if (!text) return std::unexpected(text.error());
  const auto image = codec::decodePng(std::as_bytes(std::span(text->data(), text->size())));
  if (!image) return std::unexpected(file.string() + ": " + image.error());
  if (image->width != width || image->height != height)
    return std::unexpected(file.string() + ": " + std::to_string(image->width) + "x" +
                           std::to_string(image->height) + ", the channel is " +
                           std::to_string(width) + "x" + std::to_string(height));
  std::vector<float> w(index(0, height, width));
  for (std::size_t i = 0; i < w.size(); ++i)
    w[i] =
        static_cast<float>(image->pixels[i * static_cast<std::size_t>(image->channels)]) / 255.0f;
  return w;
}

int warpSubsamples(int renderedWidth, int renderedHeight, int width, int height) {
  const double ratio = std::max(static_cast<double>(renderedWidth) / std::max(width, 1),
                                static_cast<double>(renderedHeight) / std::max(height, 1));
  return ratio <= 2.0 ? 1 : std::min(8, static_cast<int>(std::ceil(ratio / 2.0)));
}

ChannelImage warpAndBlend(const ChannelImage& rendered,
                          int width,
                          int height,
                          const WarpMesh* warp,
                          const std::vector<float>* blend) {
  ChannelImage out{width, height, std::vector<std::uint8_t>(index(0, height, width) * 4)};
  // Where in the rendered image a point (sx, sy) of the projector's image lies, in pixels.
  auto source = [&](double sx, double sy) {
    if (warp != nullptr) {
      const double gx = std::clamp(sx / width * (warp->columns - 1), 0.0, warp->columns - 1.0);
      const double gy = std::clamp(sy / height * (warp->rows - 1), 0.0, warp->rows - 1.0);
      const int i0 = std::min(static_cast<int>(gx), warp->columns - 2);
      const int j0 = std::min(static_cast<int>(gy), warp->rows - 2);
      const double fx = gx - i0, fy = gy - j0;
      auto v = [&](int i, int j) { return warp->uv[index(i, j, warp->columns)]; };
      const glm::dvec2 uv = (v(i0, j0) * (1 - fx) + v(i0 + 1, j0) * fx) * (1 - fy) +
                            (v(i0, j0 + 1) * (1 - fx) + v(i0 + 1, j0 + 1) * fx) * fy;
      return glm::dvec2(uv.x * rendered.width, uv.y * rendered.height);
    }
    if (rendered.width != width || rendered.height != height) // scaled, nothing else
      return glm::dvec2(sx / width * rendered.width, sy / height * rendered.height);
    return glm::dvec2(sx, sy);
  };
  const int n = warpSubsamples(rendered.width, rendered.height, width, height);
  for (int py = 0; py < height; ++py)
    for (int px = 0; px < width; ++px) {
      double c[4] = {0, 0, 0, 0};
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const glm::dvec2 s = source(px + (i + 0.5) / n, py + (j + 0.5) / n);
          for (int k = 0; k < 4; ++k)
            c[k] += sample(rendered, s.x, s.y, k);
        }
      const double weight =
          blend != nullptr ? static_cast<double>((*blend)[index(px, py, width)]) : 1.0;
      for (int k = 0; k < 4; ++k) {
        const double v = c[k] / (n * n) * (k < 3 ? weight : 1.0);
        out.rgba[index(px, py, width) * 4 + static_cast<std::size_t>(k)] =
            static_cast<std::uint8_t>(std::clamp(std::lround(v), 0l, 255l));
      }
    }
  return out;
}

} // namespace tellus::planet
