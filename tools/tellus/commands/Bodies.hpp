#pragma once
/**
 * @file Bodies.hpp
 * @brief The body `render`, `view` and `height` show (issue 26, docs/design/bodies.md): --body,
 * else the configuration's renderer.body; a built-in body or one of the configuration's bodies
 * made a planet::Body; the layers that lie on it; and the bare globe of a body no imagery layer
 * covers (BareLayerSource: the renderer draws its fallback colour everywhere).
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/planet/Body.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <atomic>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace tellus::commands {

/** The name of the layer BareLayerSource describes. */
inline constexpr const char* kBareLayer = "tellus.bare";

/** --body, else config's renderer.body (config may be null: --server without --config), checked
 * against the built-in and configured bodies; the usage error's text when unknown. */
std::expected<std::string, std::string> chooseBody(const cli::Args& a, const Config* config);

/** The scene's other bodies (issue 26): --bodies (comma-separated), else the configuration's
 * renderer.bodies (config may be null); each earth, moon or mars, the bodies with an ephemeris;
 * the usage error's text otherwise. */
std::expected<std::vector<std::string>, std::string> chooseSceneBodies(const cli::Args& a,
                                                                       const Config* config);

/** Each body named as one of the renderer's scene bodies, with its bundled global image from
 * `dataDir` when there (the Blue Marble, the Moon's and Mars's maps; else a flat colour). */
void addSceneBodies(planet::RendererOptions& ro,
                    const std::vector<std::string>& names,
                    const std::filesystem::path& dataDir,
                    EarthModel earth);

/** The body named (known to chooseBody); the Earth as the sphere when earth is Sphere. */
planet::Body resolveBody(const std::string& name, const Config* config, EarthModel earth);

/** A configured body as a planet::Body. */
planet::Body bodyFromConfig(const BodyConfig& b);

/** A layer's body is the one shown (layers without a configuration: every one is). */
inline bool onBody(const LayerConfig* layer, const std::string& body) {
  return layer == nullptr || layer->dataset.body == body;
}

/** A source that adds kBareLayer, a global 36-degree grid without a tile (every request is
 * answered Absent at once), to another source. */
class BareLayerSource final : public ITileSource {
public:
  explicit BareLayerSource(ITileSource& inner) : inner_(inner) {}
  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;
  bool wholePolarRows(std::string_view layer) const override {
    return inner_.wholePolarRows(layer);
  }

private:
  ITileSource& inner_;
  std::atomic<TileRequestId> nextBare_{TileRequestId{1} << 62};
};

} // namespace tellus::commands
