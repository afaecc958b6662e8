// The intake phase (planet/gl/src/TextureIntake.hpp), GL-free: received tiles kept until their
// node decodes, decode jobs built from them, decoded textures queued for upload or remembered as
// undecodable, and old tiles dropped.

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "../../planet/gl/src/TextureIntake.hpp"
#include "../../planet/gl/src/UploadQueue.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

Node& firstPlainRoot(Quadtree& tree) {
  for (const auto& r : tree.roots())
    if (r && !r->isCap()) return *r;
  throw std::logic_error("no plain root");
}

StoredTile tileBytes(std::uint64_t frame) {
  return {{std::byte{7}, std::byte{8}}, "image/jpeg", frame};
}

} // namespace

TEST(TextureIntake, ADecodingNodeTakesItsReceivedTilesIntoOneJob) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3, 128));
  addLayer(source, "clouds", grid36(3, 64));
  Layers l(source, layerOptions("base", {"clouds"}));
  LayerTextures& clouds = *(*l.set)[1].current;
  Node& node = firstPlainRoot(*clouds.tree);
  node.texture = TextureState::Decoding;
  clouds.received[node.key().firstTile()] = tileBytes(3);
  auto job = takeDecodeJob(clouds, node);
  ASSERT_TRUE(job.has_value());
  EXPECT_EQ(job->key, node.key());
  EXPECT_EQ(job->tag, clouds.tag);
  EXPECT_TRUE(job->transparent) << "an overlay's absent texels are transparent";
  EXPECT_EQ(job->width, 64);
  EXPECT_EQ(job->tileWidth, 64);
  ASSERT_EQ(job->tiles.size(), 1u);
  ASSERT_TRUE(job->tiles[0].has_value());
  EXPECT_EQ(job->tiles[0]->size(), 2u);
  EXPECT_EQ(job->contentTypes[0], "image/jpeg");
  EXPECT_TRUE(clouds.received.empty()) << "the bytes moved into the job";
  EXPECT_TRUE(clouds.decoding.contains(node.key()));
  EXPECT_FALSE(takeDecodeJob(clouds, node).has_value()) << "decoding already";
}

TEST(TextureIntake, NoJobForANodeUploadingUndecodableResidentOrMissingItsBytes) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3, 128), TileStatus::Ok);
  Layers l(source, layerOptions("base"));
  LayerTextures& base = l.set->base();
  Node& node = firstPlainRoot(*base.tree);

  base.uploading.insert(node.key());
  node.texture = TextureState::Decoding;
  EXPECT_FALSE(takeDecodeJob(base, node).has_value());
  EXPECT_EQ(node.texture, TextureState::Uploading);
  base.uploading.clear();

  node.texture = TextureState::Decoding;
  base.undecodable.insert(node.key());
  EXPECT_FALSE(takeDecodeJob(base, node).has_value());
  base.undecodable.clear();

  base.lru.insert(node.key(), 10);
  EXPECT_FALSE(takeDecodeJob(base, node).has_value());
  base.lru.erase(node.key());

  // Its tile was fetched once (its bytes went into a texture since evicted): asked for again.
  const Camera cam =
      cameraAt(l.geodesy, node.sector().south + 18.0, node.sector().west + 18.0, 2e7);
  updateLayers(*l.set, cam, 0.0);
  updateLayers(*l.set, cam, 0.1);
  RenderStats stats;
  keepReceived(base, 1, stats);
  base.received.clear();
  ASSERT_NE(base.streamer->state(node.key().firstTile()), TileFetch::Idle);
  node.texture = TextureState::Decoding;
  EXPECT_FALSE(takeDecodeJob(base, node).has_value());
  EXPECT_EQ(base.streamer->state(node.key().firstTile()), TileFetch::Idle);
  EXPECT_FALSE(base.decoding.contains(node.key()));
}

TEST(TextureIntake, ReceivedTilesAreKeptCountedAndDroppedWhenStale) {
  FakeTileSource source;
  addLayer(source, "base", grid36(2, 128), TileStatus::Ok);
  Layers l(source, layerOptions("base"));
  LayerTextures& base = l.set->base();
  const Camera cam = cameraAt(l.geodesy, 10.0, 20.0, 2e7);
  updateLayers(*l.set, cam, 0.0);
  updateLayers(*l.set, cam, 0.1); // the answers drained
  RenderStats stats;
  keepReceived(base, 5, stats);
  ASSERT_FALSE(base.received.empty());
  EXPECT_EQ(stats.bytesReceived, 3 * base.received.size());
  const std::size_t kept = base.received.size();
  dropStaleTiles(base, 604);
  EXPECT_EQ(base.received.size(), kept) << "599 frames old: kept";
  dropStaleTiles(base, 605);
  EXPECT_TRUE(base.received.empty());
}

TEST(TextureIntake, DecodedTexturesWaitForUploadOrMakeTheirNodeUndecodable) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3, 128));
  Layers l(source, layerOptions("base"));
  LayerTextures& base = l.set->base();
  const std::vector<Node*> roots = plainRoots(*base.tree);
  std::vector<DecodedTexture> done(4);
  for (std::size_t i = 0; i < done.size(); ++i) {
    done[i].key = roots[i]->key();
    done[i].tag = base.tag;
    done[i].ok = true;
    base.decoding.insert(done[i].key);
  }
  done[1].ok = false;
  done[2].tag = 999;               // its layer is gone
  base.lru.insert(done[3].key, 1); // resident meanwhile
  UploadQueue uploads;
  RenderStats stats;
  acceptDecoded(*l.set, std::move(done), uploads, stats);
  EXPECT_EQ(uploads.size(), 1u);
  EXPECT_TRUE(base.uploading.contains(roots[0]->key()));
  EXPECT_TRUE(base.undecodable.contains(roots[1]->key()));
  EXPECT_EQ(stats.decodeErrors, 1u);
  EXPECT_EQ(stats.texturesDecoded, 2u);
  EXPECT_FALSE(base.decoding.contains(roots[0]->key()));
  EXPECT_TRUE(base.decoding.contains(roots[2]->key())) << "another layer's tag touches nothing";
  EXPECT_FALSE(base.uploading.contains(roots[3]->key()));
}
