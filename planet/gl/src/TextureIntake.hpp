#pragma once
/**
 * @file TextureIntake.hpp
 * @brief The frame's intake phase (GL-free): the tiles each layer's streamer received are kept by
 * key until their node is Decoding (all its tiles arrived or absent); then the node's tiles go to
 * a TextureDecoder worker as one job; decoded textures come back and wait in the UploadQueue.
 * Every layer's own node states drive it: a node already uploading shows as Uploading, a resident
 * or undecodable one is never decoded again, and tiles whose bytes went into a texture since
 * evicted are asked for again.
 */

#include "LayerSet.hpp"
#include "TextureDecoder.hpp"

#include <cstdint>
#include <optional>

namespace tellus::planet {

class UploadQueue;

/** The tiles l's streamer received, kept (with the frame they came in) until their node decodes;
 * their bytes are added to stats.bytesReceived. */
void keepReceived(LayerTextures& l, std::uint64_t frame, RenderStats& stats);

/** The node's decode job when it is due: its tiles all arrived (Decoding), it is not decoding,
 * undecodable or resident. Its received tiles move into the job (an absent one as nullopt) and it
 * counts as decoding. nullopt when nothing is to be done, and then: a node whose texture is
 * uploading is marked Uploading; a tile whose bytes went into an evicted texture is forgotten by
 * the streamer (fetched again). */
std::optional<DecodeJob> takeDecodeJob(LayerTextures& l, Node& node);

/** The due nodes of an updated layer to the decoder: its roots, its draw list, and for an absent
 * node the nearest ancestor that is not (what it shows; the streamer asks for that). */
void launchDecodes(LayerTextures& l, TextureDecoder& decoder);

/** Decoded textures: one for a layer since swapped out is dropped, a failure makes its node
 * undecodable (never retried), one already resident is dropped, the others wait for upload
 * (their node uploading). */
void acceptDecoded(LayerSet& layers,
                   std::vector<DecodedTexture> decoded,
                   UploadQueue& uploads,
                   RenderStats& stats);

/** Tiles that arrived for nodes gone from view, kept 600 frames and not taken: dropped, and
 * forgotten by the streamer (fetched again if needed). */
void dropStaleTiles(LayerTextures& l, std::uint64_t frame);

/** The whole phase: per layer its received tiles and, when it was updated, its decodes; then the
 * decoded textures. */
void intakeTextures(LayerSet& layers,
                    TextureDecoder& decoder,
                    UploadQueue& uploads,
                    RenderStats& stats);

} // namespace tellus::planet
