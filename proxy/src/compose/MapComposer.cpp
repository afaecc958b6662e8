#include "compose/MapComposer.hpp"

#include "codec/Codecs.hpp"
#include "codec/Quantize.hpp"
#include "compose/AdmittingLru.hpp"
#include "compose/JpegRaw.hpp"
#include "tiles/WorkerPool.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <span>
#include <unordered_map>

namespace tellus {

struct MapComposer::Pool {
  WorkerPool workers;
  explicit Pool(int n) : workers(n) {}
};

namespace {

/** How fresh an origin is, for "the least fresh tile" (X-Cache of a composed map). */
int staleness(TileOrigin o) noexcept {
  switch (o) {
  case TileOrigin::Hit:
    return 0;
  case TileOrigin::Miss:
    return 1;
  case TileOrigin::Stale:
    return 2;
  case TileOrigin::Offline:
    return 3;
  }
  return 3;
}

std::optional<std::vector<std::byte>> bytesOf(const TileAnswer& a) {
  if (a.file) return a.file->readAll();
  return a.bytes;
}

/**
 * Pixel buffers kept by each composer thread between maps: a map decodes a dozen tiles of the same
 * size and fills a canvas of the same size as the last one, so reusing the storage spares the
 * allocation, the kernel's page faults and the clearing of fresh memory (a third of the CPU time
 * of a 1024x768 map before, by perf).
 */
struct Buffers {
  std::vector<std::vector<std::uint8_t>> spare;
  std::vector<std::uint8_t> canvas;
  std::vector<std::uint8_t> cb, cr; // the chroma planes of a map composed as YCbCr
  std::vector<std::uint8_t> take() {
    if (spare.empty()) return {};
    auto b = std::move(spare.back());
    spare.pop_back();
    return b;
  }
  void give(std::vector<std::uint8_t>&& b) {
    // At most 16 tiles' worth (about 12 MiB of 512-pixel RGB) stays per thread.
    if (spare.size() < 16 && b.capacity() > 0 && b.capacity() <= (4u << 20))
      spare.push_back(std::move(b));
  }
};
thread_local Buffers buffers;

/** A decoded tile and the samples view of it (or of its Y, Cb and Cr planes, stored one after the
 * other in `rgb`); its pixel storage goes back to the thread's buffers. */
struct Decoded {
  TileSamples view{};
  std::array<TileSamples, 3> planes{};
  std::vector<std::uint8_t> rgb;
  std::vector<std::int16_t> heights;
  Decoded() = default;
  Decoded(const Decoded&) = delete;
  Decoded& operator=(const Decoded&) = delete;
  ~Decoded() { buffers.give(std::move(rgb)); }
};

struct KeyLess {
  bool operator()(const TileKey& a, const TileKey& b) const noexcept {
    return std::tie(a.level, a.row, a.col) < std::tie(b.level, b.row, b.col);
  }
};

} // namespace

/** Decoded tiles by their ETag, least recently used first out, within a byte budget; a tile is
 * kept once it is used often enough (AdmittingLru.hpp). */
class MapComposer::DecodedCache : public AdmittingLru<Decoded> {
public:
  using AdmittingLru::AdmittingLru;
};

struct MapComposer::Job {
  struct Layer {
    ComposeLayer spec;
    const TileGrid* grid = nullptr;
    std::int32_t level = 0;
    std::vector<ComposeTile> keys;   // with the part of each tile that is sampled
    std::vector<TileAnswer> answers; // parallel to keys
  };
  ComposeRequest request;
  /// Composed as Y, Cb and Cr planes when every tile turns out to be a 4:2:0 JPEG: a JPEG map of
  /// one opaque imagery layer (else, or when a tile is not, the RGB path).
  bool ycc = false;
  std::vector<Layer> layers;
  std::atomic<std::size_t> pending{0};
  std::function<void(const LayerSpec&, const TileAnswer&)> onTile;
  std::function<void(ComposedMap&&)> done;
};

MapComposer::MapComposer(TileService& tiles,
                         int threads,
                         std::size_t maxTiles,
                         std::size_t decodedCacheBytes,
                         int jpegQuality)
    : tiles_(tiles), maxTiles_(maxTiles), jpegQuality_(jpegQuality),
      decodedCache_(decodedCacheBytes > 0 ? std::make_unique<DecodedCache>(decodedCacheBytes)
                                          : nullptr),
      gate_(std::make_shared<Gate>()), pool_(std::make_unique<Pool>(threads)) {
  gate_->pool = &pool_->workers;
  if (const char* e = std::getenv("TELLUS_COMPOSE_YCC"); e && std::string_view(e) == "0")
    yccDisabled_ = true;
}

std::size_t MapComposer::decodedCacheBytes() const {
  return decodedCache_ ? decodedCache_->bytes() : 0;
}

MapComposer::~MapComposer() {
  // Tile answers may still arrive (from the tile service's threads) after this: they find no
  // pool and drop their job. Jobs already queued run now, while everything they use lives.
  {
    std::lock_guard lock(gate_->mutex);
    gate_->pool = nullptr;
  }
  pool_.reset();
}

std::expected<void, std::string>
MapComposer::compose(ComposeRequest request,
                     std::function<void(const LayerSpec&, const TileAnswer&)> onTile,
                     std::function<void(ComposedMap&&)> done) {
  auto job = std::make_shared<Job>();
  job->request = std::move(request);
  job->onTile = std::move(onTile);
  job->done = std::move(done);
  const ComposeRequest& r = job->request;
  job->ycc = r.format == MapFormat::Jpeg && r.layers.size() == 1 &&
             !r.layers.front().layer->elevation && r.layers.front().opacity >= 1.0 - 1.0 / 512 &&
             !yccDisabled_;
  std::size_t total = 0;
  for (const ComposeLayer& cl : r.layers) {
    Job::Layer l;
    l.spec = cl;
    l.grid = tiles_.grid(cl.layer->name);
    if (!l.grid) return std::unexpected("no layer '" + cl.layer->name + "'");
    l.level = composeLevel(*l.grid, r.bbox, r.width, r.height, 0);
    const std::size_t left = maxTiles_ > total ? maxTiles_ - total : 0;
    auto keys = job->ycc ? composeTilesYcc(*l.grid, r.bbox, r.width, r.height, l.level, left)
                         : composeTiles(*l.grid, r.bbox, r.width, r.height, l.level, left);
    if (!keys) {
      return std::unexpected("the map needs more than " + std::to_string(maxTiles_) +
                             " tiles (level " + std::to_string(l.level) + " of layer '" +
                             cl.layer->name + "'); ask for a smaller box or fewer pixels");
    }
    total += keys->size();
    l.keys = std::move(*keys);
    l.answers.resize(l.keys.size());
    job->layers.push_back(std::move(l));
  }
  job->pending = total + 1; // +1: the loop below, so nothing finishes before every fetch starts
  const auto arrived = [this, gate = gate_, job] {
    if (job->pending.fetch_sub(1) != 1) return;
    std::lock_guard lock(gate->mutex);
    if (gate->pool) gate->pool->post([this, job] { finish(job); });
  };
  for (std::size_t li = 0; li < job->layers.size(); ++li) {
    Job::Layer& l = job->layers[li];
    for (std::size_t k = 0; k < l.keys.size(); ++k) {
      tiles_.getTile(
          l.spec.layer->name,
          l.spec.time,
          l.keys[k].key,
          [job, li, k, arrived](TileAnswer&& a) {
            job->layers[li].answers[k] = std::move(a);
            arrived();
          },
          FetchGate{r.fetchBudget, r.client});
    }
  }
  arrived();
  return {};
}

void MapComposer::finish(const std::shared_ptr<Job>& job) {
  ComposedMap map;
  try {
    const ComposeRequest& r = job->request;
    // The validators first: a client that has this map gets 304 before anything is decoded.
    std::string validators = std::string(toString(r.format)) + "|" + std::to_string(r.width) + "x" +
                             std::to_string(r.height) + "|" + (r.transparent ? "t" : "o") + "|" +
                             std::to_string(r.bgcolor.value_or(0x1000000));
    char box[128];
    std::snprintf(box,
                  sizeof box,
                  "|%.17g,%.17g,%.17g,%.17g",
                  r.bbox.west,
                  r.bbox.south,
                  r.bbox.east,
                  r.bbox.north);
    validators += box;
    bool complete = true;
    bool failed = false;
    std::string failure;
    map.origin = TileOrigin::Hit;
    map.maxAgeSeconds = 86400 * 365;
    for (const auto& l : job->layers) {
      validators +=
          "|" + l.spec.layer->name + "@" + l.spec.time + "#" + std::to_string(l.spec.opacity);
      map.maxAgeSeconds = std::min<std::int64_t>(map.maxAgeSeconds, l.spec.layer->maxAge.count());
      for (const TileAnswer& a : l.answers) {
        if (job->onTile) job->onTile(*l.spec.layer, a);
        if (staleness(a.origin) > staleness(map.origin)) map.origin = a.origin;
        if (a.kind == TileAnswer::Kind::Tile) {
          validators += a.etag;
        } else {
          complete = false;
          if (a.kind == TileAnswer::Kind::Error) {
            failed = true;
            failure = a.message;
            const auto rank = [](TileAnswer::Failure f) {
              return f == TileAnswer::Failure::Unavailable  ? 2
                     : f == TileAnswer::Failure::OverBudget ? 1
                                                            : 0;
            };
            if (rank(a.failure) > rank(map.failure)) map.failure = a.failure;
            map.retryAfterSeconds = std::max(map.retryAfterSeconds, a.retryAfterSeconds);
          }
        }
      }
    }
    char etag[24];
    std::snprintf(etag,
                  sizeof etag,
                  "\"%016llx\"",
                  static_cast<unsigned long long>(stableHash64(validators)));
    map.etag = etag;
    if (complete && !r.ifNoneMatch.empty() &&
        (r.ifNoneMatch == "*" || r.ifNoneMatch.find(map.etag) != std::string::npos)) {
      map.kind = ComposedMap::Kind::NotModified;
      return job->done(std::move(map));
    }

    // Decode what arrived; fill the holes from coarser cached tiles.
    // Opaque output (JPEG, 24-bit PNG, PNG without TRANSPARENT) composes on an RGB canvas; a JPEG
    // map of one opaque layer of 4:2:0 JPEG tiles on Y, Cb and Cr planes (see JpegRaw.hpp).
    const bool png8 = r.format == MapFormat::Png8;
    const int cc = r.format == MapFormat::Png32 ||
                           (r.transparent &&
                            (r.format == MapFormat::Png || png8 || r.format == MapFormat::Tiff))
                       ? 4
                       : 3;
    std::vector<std::uint8_t>& canvas = buffers.canvas;
    std::vector<std::int16_t> heights;
    // One layer of the other kind than the map, before it is drawn over the map (see
    // ComposeRequest::layers).
    std::vector<std::int16_t> layerHeights;
    std::vector<std::uint8_t> layerPicture;
    const auto pixels = static_cast<std::size_t>(r.width) * static_cast<std::size_t>(r.height);
    const std::uint32_t bgColour = r.bgcolor.value_or(0xFFFFFF);
    const std::uint8_t bg[4] = {static_cast<std::uint8_t>(bgColour >> 16),
                                static_cast<std::uint8_t>(bgColour >> 8),
                                static_cast<std::uint8_t>(bgColour),
                                static_cast<std::uint8_t>(r.transparent ? 0 : 255)};
    std::optional<ChromaLayout> chroma;
    if (job->ycc) chroma = chromaLayout(*job->layers.front().grid, r.bbox, r.width, r.height);
    const auto fill = [&](bool ycc) {
      if (r.heights) {
        heights.assign(pixels, r.noData);
      } else if (ycc) {
        // Nothing to fill: composePlane writes every sample of the planes, the background where
        // no tile covers it (a map's single layer; the RGB path fills again if it takes over).
      } else {
        canvas.resize(pixels * static_cast<std::size_t>(cc));
        // The first row pixel by pixel, the others copied from it.
        const auto rowBytes = static_cast<std::size_t>(r.width) * static_cast<std::size_t>(cc);
        for (std::size_t p = 0; p < static_cast<std::size_t>(r.width); ++p)
          std::copy(bg, bg + cc, &canvas[p * static_cast<std::size_t>(cc)]);
        for (std::size_t y = 1; y < static_cast<std::size_t>(r.height); ++y)
          std::memcpy(&canvas[y * rowBytes], canvas.data(), rowBytes);
      }
    };
    std::size_t missing = 0;
    // Composes every layer; false (having composed nothing) when `ycc` and a tile is not a 4:2:0
    // JPEG, so that the map is made on the RGB path instead.
    const auto composeLayers = [&](bool ycc) -> bool {
      for (const auto& l : job->layers) {
        const LayerSpec& spec = *l.spec.layer;
        const GridSpec& g = l.grid->spec();
        std::map<TileKey, std::shared_ptr<const Decoded>, KeyLess> decoded;
        bool notYcc = false;
        // Only the part of a tile that is sampled is decoded (JPEG: whole blocks around it).
        const auto decode =
            [&](const TileKey& key,
                const TileAnswer& a,
                const std::array<std::int32_t, 4>* region) -> std::shared_ptr<const Decoded> {
          // Decoded tiles are kept (whole) in an LRU by their ETag, which names their bytes.
          const std::string cacheKey =
              spec.name + '\n' + l.spec.time + '\n' + a.etag + (ycc ? "\nycc" : "");
          bool keep = false;
          if (decodedCache_ && !a.etag.empty()) {
            if (auto hit = decodedCache_->get(cacheKey)) return hit;
            // A tile that maps keep asking for is decoded whole and kept; one that is not (yet)
            // worth a place is decoded only in the part this map samples.
            const auto texels =
                static_cast<std::size_t>(g.tileWidth) * static_cast<std::size_t>(g.tileHeight);
            keep = decodedCache_->admits(cacheKey,
                                         spec.elevation ? texels * 2
                                         : ycc          ? texels * 3 / 2
                                                        : texels * 3);
            if (keep) region = nullptr;
          }
          const std::string_view type =
              a.contentType.empty() ? std::string_view(spec.dataset.mimeType) : a.contentType;
          if (ycc && type != "image/jpeg") {
            notYcc = true;
            return nullptr;
          }
          auto bytes = bytesOf(a);
          if (!bytes) return nullptr;
          ++map.decodedTiles;
          auto d = std::make_shared<Decoded>();
          if (spec.elevation) {
            auto h = decodeHeights(*bytes, spec.dataset.mimeType, g.tileWidth, g.tileHeight);
            if (!h) return nullptr;
            d->heights = std::move(*h);
            d->view = TileSamples{g.tileWidth, g.tileHeight, 1, nullptr, d->heights.data()};
          } else if (ycc) {
            const auto w = static_cast<std::size_t>(g.tileWidth);
            const auto h = static_cast<std::size_t>(g.tileHeight);
            if (!keep) d->rgb = buffers.take(); // a kept tile gets storage of its own size
            d->rgb.resize(w * h + 2 * (w / 2) * (h / 2));
            std::uint8_t* y = d->rgb.data();
            std::uint8_t* cb = y + w * h;
            std::uint8_t* cr = cb + (w / 2) * (h / 2);
            std::string message;
            switch (codecs::decodeJpegYcc(
                *bytes, g.tileWidth, g.tileHeight, region, y, cb, cr, message)) {
            case codecs::YccDecode::Ok:
              break;
            case codecs::YccDecode::NotYcc420:
              notYcc = true;
              return nullptr;
            case codecs::YccDecode::Failed:
              return nullptr;
            }
            d->planes = {TileSamples{g.tileWidth, g.tileHeight, 1, y, nullptr},
                         TileSamples{g.tileWidth / 2, g.tileHeight / 2, 1, cb, nullptr},
                         TileSamples{g.tileWidth / 2, g.tileHeight / 2, 1, cr, nullptr}};
          } else {
            if (!keep) d->rgb = buffers.take();
            const auto channels =
                decodeImageryInto(*bytes, type, g.tileWidth, g.tileHeight, d->rgb, region);
            if (!channels) return nullptr;
            d->view = TileSamples{g.tileWidth, g.tileHeight, *channels, d->rgb.data(), nullptr};
          }
          (void)key;
          // Counted by what they hold (storage of their own size, not a reused larger buffer).
          if (keep)
            decodedCache_->put(
                cacheKey, d, d->rgb.capacity() + d->heights.capacity() * sizeof(std::int16_t));
          return d;
        };
        std::vector<TileKey> holes;
        for (std::size_t k = 0; k < l.keys.size() && !notYcc; ++k) {
          const TileAnswer& a = l.answers[k];
          std::shared_ptr<const Decoded> d;
          if (a.kind == TileAnswer::Kind::Tile) d = decode(l.keys[k].key, a, &l.keys[k].region);
          if (d) {
            decoded.emplace(l.keys[k].key, std::move(d));
          } else {
            holes.push_back(l.keys[k].key);
          }
        }
        if (notYcc) return false;
        // Each hole: the nearest cached ancestor (looked up once per ancestor).
        std::map<TileKey, bool, KeyLess> looked;
        for (TileKey key : holes) {
          while (key.level > 0) {
            const auto parent = l.grid->parent(key);
            if (!parent) break;
            key = *parent;
            if (auto it = looked.find(key); it != looked.end()) {
              if (it->second) break;
              continue;
            }
            bool found = false;
            if (auto a = tiles_.cachedTile(spec.name, l.spec.time, key)) {
              if (auto d = decode(key, *a, nullptr)) {
                decoded.emplace(key, std::move(d));
                found = true;
                if (staleness(a->origin) > staleness(map.origin)) map.origin = a->origin;
                validators += a->etag;
              }
            }
            if (notYcc) return false;
            looked.emplace(key, found);
            if (found) break;
          }
        }
        map.tiles += decoded.size();
        if (ycc) {
          // The three planes, each from the tiles' plane of the same index, each sample written
          // (the background's Y, Cb or Cr where no tile covers it).
          const auto ycbcr = codecs::rgbToYcc(bg[0], bg[1], bg[2]);
          ComposeStats stats;
          for (int plane = 0; plane < 3; ++plane) {
            const TileLookup lookup = [&decoded, plane](const TileKey& key) -> const TileSamples* {
              const auto it = decoded.find(key);
              return it == decoded.end() ? nullptr
                                         : &it->second->planes[static_cast<std::size_t>(plane)];
            };
            std::vector<std::uint8_t>& target = plane == 0   ? canvas
                                                : plane == 1 ? buffers.cb
                                                             : buffers.cr;
            const auto background = ycbcr[static_cast<std::size_t>(plane)];
            const ComposeStats s = plane == 0 ? composePlane(*l.grid,
                                                             r.bbox,
                                                             r.width,
                                                             r.height,
                                                             l.level,
                                                             0,
                                                             lookup,
                                                             background,
                                                             target)
                                              : composePlane(chroma->grid,
                                                             chroma->box,
                                                             chroma->width,
                                                             chroma->height,
                                                             l.level,
                                                             0,
                                                             lookup,
                                                             background,
                                                             target);
            if (plane == 0) stats = s; // the map's pixels are the luma's
          }
          map.fallbackPixels += stats.fallbackPixels;
          missing += stats.missingPixels;
          continue;
        }
        const TileLookup lookup = [&decoded](const TileKey& key) -> const TileSamples* {
          const auto it = decoded.find(key);
          return it == decoded.end() ? nullptr : &it->second->view;
        };
        // Every level of the grid is served (firstLevel is an upstream offset): first level 0.
        ComposeStats stats;
        if (spec.elevation && r.heights) {
          stats = composeHeights(
              *l.grid, r.bbox, r.width, r.height, l.level, 0, lookup, spec.noData, heights);
        } else if (spec.elevation) { // heights in a picture: grey over the canvas
          layerHeights.assign(pixels, spec.noData);
          stats = composeHeights(
              *l.grid, r.bbox, r.width, r.height, l.level, 0, lookup, spec.noData, layerHeights);
          drawHeightsAsGrey(layerHeights, spec.noData, l.spec.opacity, canvas, cc);
        } else if (r.heights) { // a picture in heights: its luminance where it is opaque
          layerPicture.assign(pixels * 4, 0);
          stats = composeImagery(
              *l.grid, r.bbox, r.width, r.height, l.level, 0, lookup, 1.0, layerPicture, 4);
          drawLuminanceAsHeights(layerPicture, heights);
        } else {
          stats = composeImagery(
              *l.grid, r.bbox, r.width, r.height, l.level, 0, lookup, l.spec.opacity, canvas, cc);
        }
        map.fallbackPixels += stats.fallbackPixels;
        missing += stats.missingPixels;
      }
      return true;
    };
    bool ycc = job->ycc && chroma.has_value();
    {
      // What a retry on the RGB path starts again from.
      const std::string validatorsBefore = validators;
      const TileOrigin originBefore = map.origin;
      fill(ycc);
      if (!composeLayers(ycc)) {
        ycc = false;
        validators = validatorsBefore;
        map.origin = originBefore;
        map.decodedTiles = 0;
        map.tiles = 0;
        map.fallbackPixels = 0;
        missing = 0;
        fill(false);
        composeLayers(false);
      }
    }
    if (failed && missing > 0) {
      // An upstream failed and nothing cached covers the hole: an error, not a map with a hole
      // that a client would keep.
      map.kind = ComposedMap::Kind::Error;
      map.message = "part of the map is not available: " + failure;
      return job->done(std::move(map));
    }
    if (!complete) {
      // Filled in from coarser levels (or empty where the upstream has nothing): not for long.
      map.maxAgeSeconds = std::min<std::int64_t>(map.maxAgeSeconds, 60);
      std::snprintf(etag,
                    sizeof etag,
                    "\"%016llx\"",
                    static_cast<unsigned long long>(stableHash64(validators)));
      map.etag = etag;
    }
    std::expected<std::vector<std::byte>, std::string> encoded;
    if (r.heights) {
      encoded = encodeHeights(r.format == MapFormat::Png ? "image/png" : toString(r.format),
                              r.width,
                              r.height,
                              heights.data());
    } else {
      if (ycc) {
        encoded = codecs::encodeJpegYcc(
            r.width, r.height, canvas.data(), buffers.cb.data(), buffers.cr.data(), jpegQuality_);
      } else if (png8) {
        const PalettedImage p = quantize(canvas.data(), cc, pixels);
        encoded = codecs::encodePngPalette(r.width, r.height, p.palette, p.indices.data());
      } else {
        encoded = encodeImage(r.format == MapFormat::Jpeg   ? "image/jpeg"
                              : r.format == MapFormat::Tiff ? "image/tiff"
                                                            : "image/png",
                              r.width,
                              r.height,
                              cc,
                              canvas.data(),
                              false,
                              jpegQuality_);
      }
    }
    if (!encoded) {
      map.kind = ComposedMap::Kind::Error;
      map.message = "cannot encode the map: " + encoded.error();
      return job->done(std::move(map));
    }
    if (canvas.capacity() > (16u << 20)) canvas = {}; // a huge map's canvas is not kept
    if (buffers.cb.capacity() > (4u << 20)) buffers.cb = buffers.cr = {};
    map.kind = ComposedMap::Kind::Map;
    map.bytes = std::move(*encoded);
    map.contentType = std::string(contentTypeOf(r.format));
    job->done(std::move(map));
  } catch (const std::exception& e) {
    ComposedMap failedMap;
    failedMap.kind = ComposedMap::Kind::Error;
    failedMap.message = std::string("cannot compose the map: ") + e.what();
    job->done(std::move(failedMap));
  }
}

} // namespace tellus
