#pragma once
/**
 * @file LayerAnimation.hpp
 * @brief Time that plays, in the frame (issue 24): the animated layers' TimeAnimation and
 * TimePrefetcher (LayerSlot::animation, ::prefetch) driven at three points of
 * Renderer::frame, GL-free:
 *
 *   before the update phase   stepAnimations: each animation told the frame clock and the time its
 *                             layer shows; the instant it asks for made the layer's pending time
 *                             (LayerSet::setTime) unless shown or pending already
 *   after the update phase    fetchAhead: the tiles of the next instants for the layer's drawn
 *                             nodes (the pending time's tree when there is one: the view's own)
 *   after the swaps           observeAnimations: what each layer shows now, so that the frame's
 *                             statistics say "playing" once the asked instant swapped in
 *
 * The swap itself is LayerSet's (all at once when the pending time's tiles are there), so an
 * animated layer never shows a frame that mixes two times.
 */

#include "LayerSet.hpp"

namespace tellus::planet {

void stepAnimations(LayerSet& layers, double nowS);
void fetchAhead(LayerSet& layers);
void observeAnimations(LayerSet& layers, double nowS);

} // namespace tellus::planet
