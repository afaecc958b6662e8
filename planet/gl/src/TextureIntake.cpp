#include "TextureIntake.hpp"

#include "UploadQueue.hpp"

#include <utility>

namespace tellus::planet {

void keepReceived(LayerTextures& l, std::uint64_t frame, RenderStats& stats) {
  for (ReceivedTile& r : l.streamer->takeReceived()) {
    stats.bytesReceived += r.result.bytes.size();
    l.received[r.key] = {std::move(r.result.bytes), std::move(r.result.contentType), frame};
  }
}

std::optional<DecodeJob> takeDecodeJob(LayerTextures& l, Node& node) {
  const NodeKey& k = node.key();
  if (l.uploading.contains(k)) {
    node.texture = TextureState::Uploading;
    return std::nullopt;
  }
  if (node.texture != TextureState::Decoding || l.decoding.contains(k) || l.undecodable.contains(k))
    return std::nullopt;
  if (l.lru.resident(k)) return std::nullopt;
  const NodeTiles& tiles = l.streamer->nodeTiles();
  bool missing = false;
  for (std::int64_t i = 0; i < tiles.count(k); ++i) {
    const TileKey t = tiles.tile(k, i);
    if (l.streamer->state(t) != TileFetch::Absent && !l.received.contains(t)) {
      // Its bytes went into an earlier texture that was since evicted: ask again.
      l.streamer->forget({t.level, t.row, t.col, 1});
      missing = true;
    }
  }
  if (missing) return std::nullopt;
  DecodeJob job;
  job.key = k;
  job.width = node.isCap() ? l.texWidth * kCapTextureWidthFactor : l.texWidth;
  job.height = l.texHeight;
  job.tileWidth = tiles.wholeCap(k) ? job.width : l.texWidth; // a whole row: one image
  job.tileHeight = l.texHeight;
  job.transparent = l.overlay;
  job.tag = l.tag;
  job.valueFormat = l.valueFormat;
  for (std::int64_t i = 0; i < tiles.count(k); ++i) {
    const auto it = l.received.find(tiles.tile(k, i));
    if (it == l.received.end()) {
      job.tiles.emplace_back(std::nullopt);
      job.contentTypes.emplace_back();
    } else {
      job.tiles.emplace_back(std::move(it->second.bytes));
      job.contentTypes.push_back(std::move(it->second.contentType));
      l.received.erase(it);
    }
  }
  l.decoding.insert(k);
  return job;
}

void launchDecodes(LayerTextures& l, TextureDecoder& decoder) {
  const auto launch = [&](Node& node) {
    if (auto job = takeDecodeJob(l, node)) decoder.submit(std::move(*job));
  };
  for (const auto& root : l.tree->roots())
    if (root) launch(*root);
  for (Node* n : l.tree->drawList()) {
    launch(*n);
    if (n->texture == TextureState::Absent)
      for (Node* a = n->parent(); a != nullptr; a = a->parent())
        if (a->texture != TextureState::Absent) {
          launch(*a);
          break;
        }
  }
}

void acceptDecoded(LayerSet& layers,
                   std::vector<DecodedTexture> decoded,
                   UploadQueue& uploads,
                   RenderStats& stats) {
  for (DecodedTexture& d : decoded) {
    LayerTextures* l = layers.byTag(d.tag);
    if (l == nullptr) continue; // its layer was swapped out meanwhile
    l->decoding.erase(d.key);
    if (!d.ok) {
      ++stats.decodeErrors;
      l->undecodable.insert(d.key);
      continue;
    }
    ++stats.texturesDecoded;
    if (l->lru.resident(d.key)) continue;
    l->uploading.insert(d.key);
    uploads.push(std::move(d));
  }
}

void dropStaleTiles(LayerTextures& l, std::uint64_t frame) {
  std::erase_if(l.received, [&](const auto& e) {
    if (frame - e.second.frame < 600) return false;
    l.streamer->forget({e.first.level, e.first.row, e.first.col, 1});
    return true;
  });
}

void intakeTextures(LayerSet& layers,
                    TextureDecoder& decoder,
                    UploadQueue& uploads,
                    RenderStats& stats) {
  layers.forEach([&](LayerTextures& l) {
    keepReceived(l, stats.frames, stats);
    if (l.updated) launchDecodes(l, decoder);
  });
  acceptDecoded(layers, decoder.takeDone(), uploads, stats);
}

} // namespace tellus::planet
