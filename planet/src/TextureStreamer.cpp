#include <tellus/planet/ScreenArea.hpp>
#include <tellus/planet/TextureFallback.hpp>
#include <tellus/planet/TextureStreamer.hpp>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <utility>

namespace tellus::planet {

struct TextureStreamer::Inbox {
  std::mutex mutex;
  std::vector<std::pair<std::uint64_t, TileResult>> done;
};

namespace {
// Roots are scored above anything a node's area can reach (a 1e9-pixel viewport is 1e9).
constexpr double kRootBoost = 1e15;
} // namespace

TextureStreamer::TextureStreamer(ITileSource& source, StreamParams params)
    : source_(source), params_(std::move(params)), inbox_(std::make_shared<Inbox>()) {}

TextureStreamer::~TextureStreamer() {
  for (auto& [key, e] : tiles_)
    if (e.state == TileFetch::InFlight) source_.cancel(e.id);
  // A callback that still runs finds the inbox gone (it holds a weak_ptr): nothing dangles.
}

TileFetch TextureStreamer::state(const TileKey& key) const noexcept {
  const auto it = tiles_.find(key);
  return it == tiles_.end() ? TileFetch::Idle : it->second.state;
}

double TextureStreamer::score(const TileKey& key) const noexcept {
  const auto it = tiles_.find(key);
  return it == tiles_.end() ? 0.0 : it->second.score;
}

std::vector<ReceivedTile> TextureStreamer::takeReceived() {
  return std::exchange(received_, {});
}

void TextureStreamer::forget(const NodeKey& key) {
  for (std::int64_t i = 0; i < nodeTiles_.count(key); ++i) {
    const auto it = tiles_.find(nodeTiles_.tile(key, i));
    if (it != tiles_.end() && it->second.state == TileFetch::Received)
      it->second.state = TileFetch::Idle;
  }
}

void TextureStreamer::drain(double nowS) {
  std::vector<std::pair<std::uint64_t, TileResult>> done;
  {
    std::lock_guard lock(inbox_->mutex);
    done.swap(inbox_->done);
  }
  for (auto& [token, result] : done) {
    const auto t = byToken_.find(token);
    if (t == byToken_.end()) continue; // cancelled or superseded
    const TileKey key = t->second;
    byToken_.erase(t);
    Entry& e = tiles_[key];
    if (e.state != TileFetch::InFlight || e.token != token) continue;
    --stats_.inFlight;
    // A whole row or span refused (a WMS's size limit, an error): the layer's caps (merged
    // nodes) are composed of their rows' tiles from now on, as where the source cannot give them
    // whole; not there (offline, not cached): that node's.
    if (result.status != TileStatus::Ok) {
      const bool row = nodeTiles_.isWholeRow(key);
      if (nodeTiles_.refused(key, result.status == TileStatus::Failed))
        ++(row ? stats_.wholeRowsRefused : stats_.wholeSpansRefused);
    }
    switch (result.status) {
    case TileStatus::Ok:
      e.state = TileFetch::Received;
      e.failures = 0;
      ++stats_.received;
      received_.push_back({key, std::move(result)});
      break;
    case TileStatus::Absent:
      e.state = TileFetch::Absent;
      ++stats_.absent;
      break;
    case TileStatus::Failed: {
      e.state = TileFetch::Failed;
      ++e.failures;
      ++stats_.failed;
      const double wait = params_.retryBaseS * std::ldexp(1.0, std::min(e.failures - 1, 30));
      e.retryAtS = nowS + std::min(wait, params_.retryMaxS);
      break;
    }
    }
  }
}

void TextureStreamer::want(const Node& node, double score, double nowS) {
  const NodeKey& k = node.key();
  for (std::int64_t i = 0; i < nodeTiles_.count(k); ++i) {
    Entry& e = tiles_[nodeTiles_.tile(k, i)];
    if (e.wantedFrame != frame_) {
      e.wantedFrame = frame_;
      e.score = score;
    } else {
      e.score = std::max(e.score, score);
    }
    if (e.state == TileFetch::Failed && nowS >= e.retryAtS) e.state = TileFetch::Idle;
  }
}

namespace {

/** Whether the node shows less than its own texture and may be asked for one. */
bool needsTexture(const Node& n) noexcept {
  return n.texture == TextureState::NoTexture || n.texture == TextureState::CheckingCache ||
         n.texture == TextureState::Fetching;
}

/** The level of the coarsest texture the node shows now (-1: the global one). */
int shownLevel(const Node& n) {
  const TexturePlan plan = planTexture(n);
  int shown = n.level();
  for (int i = 0; i < plan.partCount; ++i) {
    const TexturePart& p = plan.parts[static_cast<std::size_t>(i)];
    const int level = p.source == TextureSource::Global ? -1 : p.texture->level();
    shown = std::min(shown, level);
  }
  return shown;
}

} // namespace

void TextureStreamer::refreshState(Node& n, const TextureLru* resident) const {
  if (resident != nullptr && resident->resident(n.key())) {
    n.texture = TextureState::Finished;
    return;
  }
  if (n.texture == TextureState::Uploading) return; // the owner's step
  bool allAbsent = true, anyInFlight = false, allReceived = true;
  for (std::int64_t i = 0; i < nodeTiles_.count(n.key()); ++i) {
    const TileFetch f = state(nodeTiles_.tile(n.key(), i));
    allAbsent = allAbsent && f == TileFetch::Absent;
    anyInFlight = anyInFlight || f == TileFetch::InFlight;
    allReceived = allReceived && (f == TileFetch::Received || f == TileFetch::Absent);
  }
  n.texture = allAbsent     ? TextureState::Absent
              : anyInFlight ? TextureState::CheckingCache
              : allReceived ? TextureState::Decoding
                            : TextureState::NoTexture;
}

void TextureStreamer::wantCandidates(Quadtree& tree,
                                     const Camera& camera,
                                     double nowS,
                                     const TextureLru* resident) {
  // Only what is drawn (issue 29): a root off screen, or above drawn nodes, is not fetched; what
  // a drawn node lacks shows its nearest resident ancestor or the global texture.
  for (Node* n : tree.drawList()) {
    refreshState(*n, resident);
    if (n->texture == TextureState::Absent) {
      wantAncestorOf(*n, camera, nowS, resident);
      continue;
    }
    if (!needsTexture(*n) || overviewSuffices(*n, overviewFactor_)) continue;
    ++stats_.candidates;
    if (n->level() == 0) { // drawn roots first: then every drawn node has a texture of its own
      want(*n, kRootBoost, nowS);
      continue;
    }
    const int shown = shownLevel(*n);
    const double area = nodeScreenArea(camera, n->geometry());
    want(*n, area * (1.0 + static_cast<double>(n->level() - shown)), nowS);
  }
}

// Nothing here (past a regional dataset's edge, below a partial dataset's deepest level): the
// node shows its nearest ancestor that has a texture, which the tree may have split past without
// ever asking for it. Ask for the nearest one not known to be absent.
void TextureStreamer::wantAncestorOf(const Node& n,
                                     const Camera& camera,
                                     double nowS,
                                     const TextureLru* resident) {
  for (Node* a = n.parent(); a != nullptr; a = a->parent()) {
    refreshState(*a, resident);
    if (a->texture == TextureState::Absent) continue;
    if (needsTexture(*a)) {
      ++stats_.candidates;
      want(*a, nodeScreenArea(camera, n.geometry()), nowS);
    }
    break;
  }
}

void TextureStreamer::settleInFlight() {
  scratch_.clear();
  for (auto& [key, e] : tiles_) {
    if (e.state == TileFetch::InFlight) {
      if (e.wantedFrame != frame_) {
        if (source_.cancel(e.id)) {
          byToken_.erase(e.token);
          e.state = TileFetch::Idle;
          --stats_.inFlight;
          ++stats_.cancelled;
        }
      } else if (e.score != e.sentScore) {
        source_.reprioritize(e.id, e.score);
        e.sentScore = e.score;
        ++stats_.reprioritized;
      }
    } else if (e.state == TileFetch::Idle && e.wantedFrame == frame_) {
      scratch_.emplace_back(e.score, key);
    }
  }
}

void TextureStreamer::requestBest() {
  if (stats_.inFlight >= params_.maxInFlight || scratch_.empty()) return;
  const std::size_t room = params_.maxInFlight - stats_.inFlight;
  const std::size_t n = std::min(room, scratch_.size());
  auto byScore = [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  };
  std::partial_sort(
      scratch_.begin(), scratch_.begin() + static_cast<std::ptrdiff_t>(n), scratch_.end(), byScore);
  for (std::size_t i = 0; i < n; ++i)
    request(scratch_[i].second);
}

void TextureStreamer::request(const TileKey& key) {
  Entry& e = tiles_[key];
  const std::uint64_t token = nextToken_++;
  e.state = TileFetch::InFlight;
  e.token = token;
  e.sentScore = e.score;
  byToken_.emplace(token, key);
  ++stats_.inFlight;
  ++stats_.requested;
  std::weak_ptr<Inbox> weak = inbox_;
  e.id = source_.request(
      nodeTiles_.address(params_.layer, params_.time, key), e.score, [weak, token](TileResult&& r) {
        if (auto inbox = weak.lock()) {
          std::lock_guard lock(inbox->mutex);
          inbox->done.emplace_back(token, std::move(r));
        }
      });
}

void TextureStreamer::update(Quadtree& tree,
                             const Camera& camera,
                             double nowS,
                             const TextureLru* resident) {
  ++frame_;
  drain(nowS);
  stats_.candidates = 0;
  wantCandidates(tree, camera, nowS, resident);
  // Cancel what nobody wants any more; re-score what stays; collect what may be asked for.
  settleInFlight();
  requestBest();
}

} // namespace tellus::planet
