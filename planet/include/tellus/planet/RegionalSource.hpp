#pragma once
/**
 * @file RegionalSource.hpp
 * @brief Several datasets drawn as one layer (thesis 4.6.3): a global dataset plus detailed
 * regional ones. Each tile of the combined layer comes from the smallest dataset whose coverage
 * contains the whole tile and which has the tile's level; where none does, the tile is absent (the
 * renderer then shows the nearest ancestor's texture). The number of levels therefore differs by
 * region: deep where a regional dataset reaches, shallow elsewhere. Used alike for imagery and for
 * elevation (the height streamer asks the same interface).
 *
 * The datasets of one combined layer must share the grid's level-zero tile size and tile pixel
 * size, so that a key means the same sector in each (keys count from the globe's south-west
 * corner, whatever a dataset's sector). The combined layer's grid is the first dataset's with the
 * union of the sectors and the largest number of levels.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileSource.hpp>

#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct CombinedLayer {
  std::string name;                  ///< what the renderer asks for
  std::vector<std::string> datasets; ///< layers of the inner source, usually the global one first
};

class RegionalTileSource final : public ITileSource {
public:
  /** Validates the combination against the inner source: every dataset known, grids compatible,
   * names unique and not shadowing a different inner layer. The inner source must outlive this. */
  static std::expected<std::unique_ptr<RegionalTileSource>, std::string>
  create(ITileSource& inner, std::vector<CombinedLayer> layers);

  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;
  /** A layer that is not combined passes through; a combined one's caps are composed. */
  bool wholePolarRows(std::string_view layer) const override {
    return find(layer) == nullptr && inner_.wholePolarRows(layer);
  }

  /** The dataset a tile of a combined layer comes from; nullopt when none covers it. A layer that
   * is not combined passes through (its own name). */
  std::optional<std::string> datasetFor(std::string_view layer, const TileKey& key) const;

private:
  struct Dataset {
    std::string name;
    Sector sector;
    std::int32_t levels = 1;
    double area = 0.0;
  };
  struct Combined {
    std::string name;
    std::vector<Dataset> datasets; ///< smallest area first
    GridSpec grid;                 ///< the combined grid
    std::optional<TileGrid> tiles; ///< the same, validated once (tile sectors per request)
  };
  RegionalTileSource(ITileSource& inner, std::vector<Combined> layers)
      : inner_(inner), layers_(std::move(layers)) {}
  const Combined* find(std::string_view layer) const noexcept;

  ITileSource& inner_;
  std::vector<Combined> layers_;
};

} // namespace tellus::planet
