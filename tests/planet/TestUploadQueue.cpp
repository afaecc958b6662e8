// The upload phase (planet/gl/src/UploadQueue.hpp) and node textures (NodeTextures.hpp): band
// sizes (GL-free); a texture uploaded band by band over several frames under a byte budget arrives
// whole, in its layer, drawable; an upload whose layer went is dropped; the pool reuses textures of
// the tile size and deletes the others (GL).

#include "../../planet/gl/src/NodeTextures.hpp"
#include "../../planet/gl/src/UploadQueue.hpp"
#include "GlContextSupport.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

#include <climits>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

DecodedTexture pattern(const NodeKey& key, int tag, int size) {
  MipLevel base;
  base.width = base.height = size;
  base.rgba.resize(static_cast<std::size_t>(size * size * 4));
  for (std::size_t i = 0; i < base.rgba.size(); ++i)
    base.rgba[i] = static_cast<std::uint8_t>((i * 7) % 251);
  DecodedTexture d;
  d.key = key;
  d.tag = tag;
  d.ok = true;
  d.levels = buildMips(std::move(base));
  for (const MipLevel& l : d.levels)
    d.bytes += l.rgba.size();
  return d;
}

std::vector<std::uint8_t> readLevel(const GlTexture& t, int level, int size) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(size * size * 4));
  glBindTexture(GL_TEXTURE_2D, t.id());
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTexImage(GL_TEXTURE_2D, level, GL_RGBA, GL_UNSIGNED_BYTE, out.data());
  return out;
}

} // namespace

TEST(UploadQueue, ABandCarriesTheRowsThatFitAtLeastOneAndNoMoreThanAreLeft) {
  EXPECT_EQ(bandRows(4096, 256, 64), 16);
  EXPECT_EQ(bandRows(100, 256, 64), 1);
  EXPECT_EQ(bandRows(1 << 20, 256, 10), 10);
  EXPECT_EQ(bandRows(std::size_t{1} << 62, 1, 5), 5) << "no overflow past INT_MAX rows";
}

TEST(UploadQueueGl, ATextureArrivesWholeAfterItsBandsAndIsDrawableThen) {
  OPEN_GL_CONTEXT(context);
  FakeTileSource source;
  addLayer(source, "base", grid36(3, 64));
  Layers l(source, layerOptions("base"));
  LayerTextures& base = l.set->base();
  const NodeKey key = plainRoots(*base.tree)[2]->key();
  const DecodedTexture decoded = pattern(key, base.tag, 64);
  base.uploading.insert(key);
  UploadQueue queue;
  queue.push(decoded);
  const UploadPacer pacer(UploadPacing{.bytesPerFrame = 4096, .shareOfFrame = 0.0});
  const NodeTextureFormat format{context.capabilities().textureStorage, 1.0f};
  RenderStats stats;
  int frames = 0;
  while (!queue.empty() && frames < 100) {
    queue.step(*l.set, pacer, format, stats);
    ++frames;
    if (!queue.empty()) {
      EXPECT_FALSE(base.textures.contains(key)) << "not before every level";
    }
  }
  EXPECT_EQ(frames, 6) << "16 KiB level 0 in 4 KiB frames, then level 1, then the rest";
  ASSERT_TRUE(base.textures.contains(key));
  EXPECT_FALSE(base.uploading.contains(key));
  EXPECT_TRUE(base.lru.resident(key));
  EXPECT_EQ(stats.texturesUploaded, 1u);
  EXPECT_EQ(stats.bytesUploaded, decoded.bytes);
  const GlTexture& t = base.textures.at(key).texture;
  EXPECT_EQ(readLevel(t, 0, 64), decoded.levels[0].rgba);
  EXPECT_EQ(readLevel(t, 3, 8), decoded.levels[3].rgba);
  EXPECT_EQ(glGetError(), GLenum{GL_NO_ERROR});
}

TEST(UploadQueueGl, AnUploadForALayerSwappedOutIsDropped) {
  OPEN_GL_CONTEXT(context);
  FakeTileSource source;
  addLayer(source, "base", grid36(3, 64));
  addLayer(source, "clouds", grid36(3, 64));
  Layers l(source, layerOptions("base", {"clouds"}));
  l.set->setTime(1, "t1");
  const int tag = (*l.set)[1].pending->tag;
  UploadQueue queue;
  queue.push(pattern(plainRoots(*(*l.set)[1].pending->tree)[2]->key(), tag, 64));
  l.set->setTime(1, ""); // cancelled
  const UploadPacer pacer;
  RenderStats stats;
  queue.step(*l.set, pacer, NodeTextureFormat{context.capabilities().textureStorage, 1.0f}, stats);
  EXPECT_TRUE(queue.empty());
  EXPECT_EQ(stats.bytesUploaded, 0u);
  EXPECT_EQ(stats.texturesUploaded, 0u);
}

TEST(UploadQueueGl, ThePoolReusesTexturesOfTheTileSizeAndDeletesWideOnes) {
  OPEN_GL_CONTEXT(context);
  const NodeTextureFormat format{context.capabilities().textureStorage, 1.0f};
  TexturePool pool;
  std::size_t reused = 0;
  NodeTexture a = pool.acquire(64, 64, 64, 64, format, &reused);
  EXPECT_FALSE(a.wide);
  EXPECT_TRUE(glIsTexture(a.texture.id()));
  const GLuint name = a.texture.id();
  pool.release(std::move(a));
  EXPECT_EQ(pool.size(), 1u);
  NodeTexture b = pool.acquire(64, 64, 64, 64, format, &reused);
  EXPECT_EQ(b.texture.id(), name);
  EXPECT_EQ(reused, 1u);
  NodeTexture wide = pool.acquire(256, 64, 64, 64, format, &reused);
  EXPECT_TRUE(wide.wide);
  const GLuint wideName = wide.texture.id();
  GLint width = 0;
  glBindTexture(GL_TEXTURE_2D, wideName);
  glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_WIDTH, &width);
  EXPECT_EQ(width, 256);
  glBindTexture(GL_TEXTURE_2D, 0);
  pool.release(std::move(wide));
  EXPECT_EQ(pool.size(), 0u);
  EXPECT_FALSE(glIsTexture(wideName));
  std::vector<NodeTexture> many;
  for (std::size_t i = 0; i < TexturePool::kMaxFree + 2; ++i)
    many.push_back(pool.acquire(64, 64, 64, 64, format, &reused));
  for (NodeTexture& t : many)
    pool.release(std::move(t));
  EXPECT_EQ(pool.size(), TexturePool::kMaxFree);
  GLint levels = 0;
  glBindTexture(GL_TEXTURE_2D, b.texture.id());
  glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, &levels);
  EXPECT_EQ(levels + 1, nodeTextureLevels(64, 64));
  EXPECT_EQ(nodeTextureLevels(64, 64), 7);
  EXPECT_EQ(nodeTextureLevels(1024, 512), 11);
}
