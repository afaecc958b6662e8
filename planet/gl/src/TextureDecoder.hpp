#pragma once
// Decoding node textures on worker threads: the tiles of a node (one, or `span` tiles of a merged
// polar node, composed side by side and down-sampled east-west) become one RGBA8 image of the
// grid's tile size, rows from the south (GL's first row), with every mip level built on the CPU.
// A layer of values (issue 24; DecodeJob::valueFormat) becomes one level of floats instead
// (ValueTexture.hpp).

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace tellus::planet {

struct MipLevel {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba; ///< rows from the south (values: 4 bytes a float, R32F)
};

struct DecodeJob {
  NodeKey key;
  int width = 0; ///< the texture's size (the grid's tile size)
  int height = 0;
  /** One entry per tile west to east; nullopt for an absent tile (left dark, or transparent). */
  std::vector<std::optional<std::vector<std::byte>>> tiles;
  /** The tiles' content types (parallel to tiles; may be empty) and the layer's tile size, for
   * the ImageDecoder of tiles that are neither JPEG nor PNG. */
  std::vector<std::string> contentTypes;
  int tileWidth = 0;
  int tileHeight = 0;
  /** Absent tiles (and texels no tile covers) transparent rather than dark: overlay layers. */
  bool transparent = false;
  int tag = 0; ///< the caller's, returned in DecodedTexture (which layer the texture is for)
  /** A layer of values: its tiles are raw samples read by values::decode (ValueTexture.hpp). */
  std::optional<values::ValueFormat> valueFormat;
};

/** Colours are premultiplied by alpha (an opaque texture is unchanged), so that filtering and mip
 * levels never bleed the colour of transparent texels into their neighbours. */
struct DecodedTexture {
  NodeKey key;
  int tag = 0;
  bool ok = false;
  std::string error;
  std::vector<MipLevel> levels; ///< level 0 first, down to 1 x 1
  std::size_t bytes = 0;        ///< all levels
  /** A layer of values: levels is one level of floats (R32F, NaN = no data), and sample a few
   * of its finite values (ValueLayerOptions::kDataRangeSample at most) for `range: data`. */
  bool values = false;
  std::vector<float> sample;
};

/** Composes, resamples and builds the mip chain (pure; what the workers run). JPEG and PNG
 * tiles are read here; any other goes to `other` when it is set (else it is an error). */
DecodedTexture decodeTexture(const DecodeJob& job, const ImageDecoder& other = {});
/** The mip chain of an RGBA8 image whose rows are from the south (box filter). */
std::vector<MipLevel> buildMips(MipLevel base);

class TextureDecoder {
public:
  /** `threads` workers whose nice value is the process's plus `nice` (Linux sets it per thread;
   * a value it refuses is ignored). */
  explicit TextureDecoder(int threads, int nice = 0, ImageDecoder other = {});
  ~TextureDecoder();
  TextureDecoder(const TextureDecoder&) = delete;
  TextureDecoder& operator=(const TextureDecoder&) = delete;

  /** Queues a job (main thread). Never waits for a worker: the workers run at a lower priority
   * and may be preempted holding the lock, so the main thread only ever tries it (jobs wait in an
   * outbox until it gets it, at the latest at the next takeDone). */
  void submit(DecodeJob job);
  /** Finished textures since the last call (main thread); empty when a worker holds the lock. */
  std::vector<DecodedTexture> takeDone();
  /** Jobs submitted and not yet taken back (main thread). */
  std::size_t pending() const;

private:
  void run(std::stop_token stop);
  void flush();                   ///< the outbox into the queue, when the lock is free
  std::vector<DecodeJob> outbox_; ///< main thread only
  std::size_t submitted_ = 0;     ///< main thread only
  std::size_t taken_ = 0;         ///< main thread only
  mutable std::mutex mutex_;
  std::condition_variable_any wake_;
  std::deque<DecodeJob> queue_;
  std::vector<DecodedTexture> done_;
  const ImageDecoder other_; ///< set before the workers start; called by all of them
  int nice_ = 0;
  std::vector<std::jthread> workers_;
};

} // namespace tellus::planet
