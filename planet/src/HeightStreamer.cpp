#include <tellus/planet/HeightStreamer.hpp>

#include <algorithm>
#include <unordered_set>

namespace tellus::planet {

std::expected<HeightTile, std::string> decodeHeightsBil16Only(const TileKey& key,
                                                              int width,
                                                              int height,
                                                              std::span<const std::byte> bytes,
                                                              std::string_view contentType,
                                                              const HeightEncoding& encoding) {
  const bool bil =
      contentType.starts_with("application/bil16") || contentType.empty() ||
      bytes.size() == static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 2;
  if (!bil)
    return std::unexpected("elevation tiles of type '" + std::string(contentType) +
                           "' cannot be decoded here");
  return decodeBil16(key, width, height, bytes, encoding);
}

HeightStreamer::HeightStreamer(ITileSource& source,
                               const TileGrid& grid,
                               HeightStreamParams params,
                               HeightDecoder decode)
    : source_(source), grid_(grid), params_(std::move(params)), decode_(std::move(decode)),
      inbox_(std::make_shared<Inbox>()) {}

HeightStreamer::~HeightStreamer() {
  for (const auto& [key, id] : inFlight_)
    source_.cancel(id);
}

void HeightStreamer::drain(double nowS) {
  std::deque<std::pair<TileKey, std::expected<HeightTile, std::string>>> done;
  std::vector<TileKey> absent;
  std::vector<std::pair<TileKey, std::string>> failed;
  {
    std::lock_guard lock(inbox_->mutex);
    done.swap(inbox_->done);
    absent.swap(inbox_->absent);
    failed.swap(inbox_->failed);
  }
  for (auto& [key, result] : done) {
    inFlight_.erase(key);
    if (result) {
      ++stats_.received;
      ready_.emplace_back(key, std::move(*result));
    } else {
      ++stats_.decodeErrors;
      absent_[key] = true; // the same bytes would fail again
    }
  }
  for (const TileKey& key : absent) {
    inFlight_.erase(key);
    ++stats_.absent;
    absent_[key] = true;
  }
  for (const auto& [key, message] : failed) {
    inFlight_.erase(key);
    ++stats_.failed;
    retryAt_[key] = nowS + params_.retryAfterS;
  }
}

void HeightStreamer::want(std::span<const TileKey> keys, const HeightField& field, double nowS) {
  drain(nowS);
  std::unordered_set<TileKey, TileKeyHash> wished(keys.begin(), keys.end());
  // Queued requests nobody wants any more make room.
  for (auto it = inFlight_.begin(); it != inFlight_.end();) {
    if (!wished.contains(it->first) && source_.cancel(it->second))
      it = inFlight_.erase(it);
    else
      ++it;
  }
  double priority = 1e6;
  for (const TileKey& key : keys) {
    if (inFlight_.size() >= params_.maxInFlight) break;
    priority -= 1.0;
    if (field.contains(key) || inFlight_.contains(key) || absent_.contains(key)) continue;
    if (const auto r = retryAt_.find(key); r != retryAt_.end()) {
      if (nowS < r->second) continue;
      retryAt_.erase(r);
    }
    if (std::any_of(ready_.begin(), ready_.end(), [&](const auto& e) { return e.first == key; }))
      continue;
    ++stats_.requested;
    std::weak_ptr<Inbox> weak = inbox_;
    const int w = grid_.spec().tileWidth, h = grid_.spec().tileHeight;
    HeightDecoder decode = decode_;
    const HeightEncoding enc = params_.encoding;
    const VerticalDatum datum = params_.datum;
    const Sector sector = grid_.sectorOf(key);
    inFlight_[key] = source_.request({params_.layer, params_.time, key},
                                     priority,
                                     [weak, key, w, h, decode, enc, datum, sector](TileResult&& r) {
                                       auto inbox = weak.lock();
                                       if (!inbox) return;
                                       if (r.status == TileStatus::Absent) {
                                         std::lock_guard lock(inbox->mutex);
                                         inbox->absent.push_back(key);
                                         return;
                                       }
                                       if (r.status != TileStatus::Ok) {
                                         std::lock_guard lock(inbox->mutex);
                                         inbox->failed.emplace_back(key, r.message);
                                         return;
                                       }
                                       // Raw samples become metres here, once, on the source's
                                       // worker thread.
                                       auto tile = decode(key, w, h, r.bytes, r.contentType, enc);
                                       // Mean sea level onto the ellipsoid (h = H + N), once per
                                       // tile, here too.
                                       if (tile) applyVerticalDatum(*tile, sector, datum);
                                       std::lock_guard lock(inbox->mutex);
                                       inbox->done.emplace_back(key, std::move(tile));
                                     });
  }
  stats_.inFlight = inFlight_.size();
  stats_.waiting = ready_.size();
}

std::size_t HeightStreamer::deliver(HeightField& field, std::size_t maxTiles) {
  std::size_t n = 0;
  while (n < maxTiles && !ready_.empty()) {
    if (field.insert(std::move(ready_.front().second)))
      ++n;
    else
      absent_[ready_.front().first] = true; // wrong size for the grid: never usable
    ready_.pop_front();
  }
  stats_.waiting = ready_.size();
  return n;
}

bool HeightStreamer::settled(const TileKey& key, const HeightField& field) const {
  return field.contains(key) || absent_.contains(key) || retryAt_.contains(key);
}

bool HeightStreamer::busy() const {
  if (!inFlight_.empty() || !ready_.empty()) return true;
  std::lock_guard lock(inbox_->mutex);
  return !inbox_->done.empty() || !inbox_->absent.empty() || !inbox_->failed.empty();
}

} // namespace tellus::planet
