// TileCache: registering datasets. A dataset lives in the index (its row and id) and in the store
// (its folder and descriptor, from which a rebuild starts). Registering what the index already
// holds as defined writes nothing, so a restart on a full disk finds every dataset it had and
// starts.

#include "CacheCore.hpp"

#include <algorithm>

namespace tellus {

namespace {

using Result = std::expected<void, CacheError>;

CacheError invalidSpec(std::string msg) {
  return CacheError{CacheErrc::InvalidArgument, std::move(msg)};
}

std::expected<TileGrid, CacheError> validated(const DatasetSpec& spec) {
  auto grid = TileGrid::create(spec.grid);
  if (!grid) return std::unexpected(invalidSpec("dataset '" + spec.name + "': " + grid.error()));
  if (spec.extension.empty() || spec.extension.size() > 8 ||
      !std::all_of(spec.extension.begin(), spec.extension.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
      })) {
    return std::unexpected(
        invalidSpec("dataset '" + spec.name + "': extension must be 1-8 of [a-z0-9]"));
  }
  // A body is a name (it enters the hash and the index): never empty, no control characters.
  if (spec.body.empty() || std::any_of(spec.body.begin(), spec.body.end(), [](char c) {
        return static_cast<unsigned char>(c) < 0x20;
      })) {
    return std::unexpected(
        invalidSpec("dataset '" + spec.name + "': body must be a name, got '" + spec.body + "'"));
  }
  return std::move(*grid);
}

/** A refusal for lack of space, remembered and worded by the gate; other errors as they are. */
CacheError refusal(TileCache::Impl& im, const CacheError& e) {
  if (e.code != CacheErrc::DiskFull) return e;
  im.gate.noteFull();
  return im.gate.fullError(e.message);
}

/** The store's side: the folder, and the descriptor when it is not current. Failures are errors
 * only for a dataset the index does not know yet (a known one keeps working without them). */
Result prepareFolder(TileCache::Impl& im,
                     const std::string& folder,
                     const std::string& descriptor,
                     bool descriptorCurrent,
                     bool known) {
  if (auto r = im.store->prepareDataset(folder); !r) {
    if (!known) return std::unexpected(refusal(im, r.error()));
  } else if (!descriptorCurrent) {
    // The descriptor goes first: a rebuild from the store needs it, and it is harmless without a
    // row. A known dataset keeps working without it (its old descriptor stays).
    if (auto w = im.store->writeDescriptor(folder, descriptor); !w && !known)
      return std::unexpected(refusal(im, w.error()));
  }
  return {};
}

} // namespace

std::expected<DatasetId, CacheError> TileCache::registerDataset(const DatasetSpec& spec) {
  Impl& im = *impl_;
  auto grid = validated(spec);
  if (!grid) return std::unexpected(grid.error());
  const std::string folder = datasetFolder(spec);
  const std::string descriptor = serializeDatasetSpec(spec);
  // Registered already as it is now defined? Then nothing is written.
  std::optional<DatasetInfo> known;
  if (auto k = im.index->datasetInFolder(folder)) known = std::move(*k);
  auto remember = [&](const DatasetInfo& info, bool pinned) {
    DatasetInfo stored{info.id, spec, folder, info.createdAt};
    stored.spec.pinned = pinned;
    return im.datasets.remember(std::move(stored), *grid);
  };
  const bool descriptorCurrent = im.store->readDescriptor(folder) == descriptor;
  const bool pinnedCurrent = known && known->spec.pinned == spec.pinned;
  if (pinnedCurrent && descriptorCurrent) return remember(*known, known->spec.pinned);
  if (!known && im.gate.refusingNow()) {
    return std::unexpected(
        im.gate.fullError("dataset '" + spec.name + "' is not registered while the disk is full"));
  }
  if (auto r = prepareFolder(im, folder, descriptor, descriptorCurrent, known.has_value()); !r)
    return std::unexpected(r.error());
  if (pinnedCurrent) return remember(*known, known->spec.pinned);
  DatasetInfo registered;
  auto r = im.writer.submit([&]() -> Result {
    auto info = im.index->upsertDataset(spec, folder, im.clock->now());
    if (!info) return std::unexpected(info.error());
    registered = std::move(*info);
    return {};
  });
  if (!r && known) {
    // Only `pinned` could not be recorded (a full index): the dataset is there and works.
    return remember(*known, known->spec.pinned);
  }
  if (!r) return std::unexpected(refusal(im, r.error()));
  return remember(registered, spec.pinned);
}

std::optional<DatasetInfo> TileCache::dataset(DatasetId id) const {
  auto d = impl_->datasets.find(id);
  if (!d) return std::nullopt;
  return d->info;
}

std::vector<DatasetInfo> TileCache::datasets() const {
  return impl_->datasets.all();
}

std::expected<void, CacheError> TileCache::setPinned(DatasetId id, bool pinned) {
  Impl& im = *impl_;
  if (!im.datasets.find(id))
    return std::unexpected(invalidSpec("unknown dataset id " + std::to_string(id)));
  auto r = im.writer.submit([&]() -> Result { return im.index->setPinned(id, pinned); });
  if (!r) return r;
  im.datasets.setPinned(id, pinned);
  return {};
}

} // namespace tellus
