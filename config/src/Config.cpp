#include <tellus/config/Config.hpp>

#include <cstdlib>
#include <set>

namespace tellus {

const LayerConfig* Config::layer(std::string_view name) const noexcept {
  for (const auto& l : layers) {
    if (l.name == name) return &l;
  }
  return nullptr;
}

Config embeddedDefault(const std::filesystem::path& dataDir,
                       const std::filesystem::path& cacheRoot) {
  Config c;
  c.cache.root = cacheRoot;

  LayerConfig bmng;
  bmng.name = "bluemarble";
  bmng.title = "NASA Blue Marble Next Generation (topography and bathymetry, May 2004)";
  bmng.kind = LayerKind::Imagery;
  bmng.dataset.server = "local";
  bmng.dataset.name = bmng.name;
  // World Wind's BMNG level set: 36-degree level zero, 512-pixel JPEG tiles. Level 0 (0.070 deg/px)
  // is already finer than the bundled 2048x1024 image (0.176 deg/px); levels 1-2 are upsampled so
  // that a viewer can zoom in a little on the offline default.
  bmng.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
  bmng.dataset.mimeType = "image/jpeg";
  bmng.dataset.extension = "jpg";
  bmng.dataset.pinned = true; // the offline default must never be evicted
  bmng.upstream.path = dataDir / "bmng_2048x1024.jpg";
  c.layers.push_back(bmng);

  LayerConfig etopo;
  etopo.name = "etopo";
  etopo.title = "ETOPO 20' heights (metres above mean sea level)";
  etopo.kind = LayerKind::Elevation;
  etopo.dataset.server = "local";
  etopo.dataset.name = etopo.name;
  // World Wind's elevation convention: 20-degree level zero, 150-pixel BIL16 tiles (level 0 at
  // 0.133 deg/px is finer than the 20' = 0.333 deg/px source already).
  etopo.dataset.grid = GridSpec{Sector{}, 20.0, 150, 150, 3};
  etopo.dataset.mimeType = "application/bil16";
  etopo.dataset.extension = "bil";
  etopo.dataset.pinned = true;
  etopo.upstream.path = dataDir / "etopo20_int16.tif";
  c.layers.push_back(etopo);
  return c;
}

std::expected<void, std::string> validate(const Config& config) {
  std::set<std::string> names;
  for (const auto& l : config.layers) {
    const std::string where = "layer '" + l.name + "'";
    if (l.name.empty()) return std::unexpected("a layer has no name");
    if (!names.insert(l.name).second) return std::unexpected(where + ": name used twice");
    if (auto g = TileGrid::create(l.dataset.grid); !g)
      return std::unexpected(where + ": grid: " + g.error());
    const auto& m = l.dataset.mimeType;
    if (m != "image/jpeg" && m != "image/png" && m != "application/bil16" && m != "image/tiff") {
      return std::unexpected(where + ": format '" + m +
                             "' is not one of image/jpeg, image/png, "
                             "application/bil16, image/tiff");
    }
    if (!std::filesystem::exists(l.upstream.path)) {
      return std::unexpected(where + ": upstream file " + l.upstream.path.string() +
                             " does not exist");
    }
  }
  return {};
}

std::filesystem::path defaultCacheRoot() {
  if (const char* t = std::getenv("TELLUS_CACHE"); t && *t) return t;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    return std::filesystem::path(x) / "tellus";
  if (const char* h = std::getenv("HOME"); h && *h)
    return std::filesystem::path(h) / ".cache" / "tellus";
  return std::filesystem::current_path() / "tellus-cache";
}

} // namespace tellus
