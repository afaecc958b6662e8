#include "DatasetRegistry.hpp"

namespace tellus::detail {

namespace {

std::string keyText(const TileKey& k) {
  return "L" + std::to_string(k.level) + " R" + std::to_string(k.row) + " C" +
         std::to_string(k.col);
}

CacheError invalid(std::string msg) {
  return CacheError{CacheErrc::InvalidArgument, std::move(msg)};
}

} // namespace

DatasetRegistry::Result DatasetRegistry::load() {
  auto rows = index_.datasets();
  if (!rows) return std::unexpected(rows.error());
  std::map<DatasetId, std::shared_ptr<const DatasetEntry>> loaded;
  for (auto& info : *rows) {
    auto grid = TileGrid::create(info.spec.grid);
    if (!grid) continue; // a row this build cannot use; `verify` will not touch it either
    const DatasetId id = info.id;
    loaded.emplace(
        id, std::make_shared<const DatasetEntry>(DatasetEntry{std::move(info), std::move(*grid)}));
  }
  std::unique_lock lock(mutex_);
  byId_ = std::move(loaded);
  return {};
}

std::shared_ptr<const DatasetEntry> DatasetRegistry::find(DatasetId id) {
  {
    std::shared_lock lock(mutex_);
    if (auto it = byId_.find(id); it != byId_.end()) return it->second;
  }
  if (!load()) return nullptr;
  std::shared_lock lock(mutex_);
  if (auto it = byId_.find(id); it != byId_.end()) return it->second;
  return nullptr;
}

std::expected<std::shared_ptr<const DatasetEntry>, CacheError>
DatasetRegistry::checked(DatasetId id, const TileKey& key) {
  auto d = find(id);
  if (!d) return std::unexpected(invalid("unknown dataset id " + std::to_string(id)));
  if (key.level < 0 || key.level >= d->grid.numLevels() || !d->grid.isValid(key)) {
    return std::unexpected(invalid("tile " + keyText(key) + " is outside the grid of dataset '" +
                                   d->info.spec.name + "'"));
  }
  return d;
}

std::vector<DatasetInfo> DatasetRegistry::all() {
  (void)load();
  return known();
}

std::vector<DatasetInfo> DatasetRegistry::known() const {
  std::shared_lock lock(mutex_);
  std::vector<DatasetInfo> out;
  for (const auto& [id, d] : byId_)
    out.push_back(d->info);
  return out;
}

DatasetId DatasetRegistry::remember(DatasetInfo info, const TileGrid& grid) {
  const DatasetId id = info.id;
  std::unique_lock lock(mutex_);
  byId_.insert_or_assign(id,
                         std::make_shared<const DatasetEntry>(DatasetEntry{std::move(info), grid}));
  return id;
}

void DatasetRegistry::setPinned(DatasetId id, bool pinned) {
  std::unique_lock lock(mutex_);
  if (auto it = byId_.find(id); it != byId_.end()) {
    auto updated = std::make_shared<DatasetEntry>(*it->second);
    updated->info.spec.pinned = pinned;
    it->second = std::move(updated);
  }
}

} // namespace tellus::detail
