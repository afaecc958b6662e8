#pragma once
/**
 * @file TimeAnimation.hpp
 * @brief Time that plays (issue 24): a layer's TIME stepped through a list of instants at a rate,
 * on an injected clock, never faster than the layer's tiles arrive. GL-free; the renderer drives
 * one per animated layer (Renderer::animateLayer) and `tellus view`'s keys play, pause and step
 * it.
 *
 * The instants come checked: `tellus` expands `--animate LAYER=A/B/P` into the layer's declared
 * grid (tools/tellus/cli LayerTimes.hpp, which refuses an instant the layer does not declare);
 * here they are only a non-empty list of distinct strings.
 *
 * Each frame, update(now, shown) is given the clock (seconds, never decreasing) and the time the
 * layer shows now (the renderer's current time, which changes only when a pending time has all
 * of its tiles and swaps in whole). The animation asks for one instant at a time (target()):
 *
 * - the first update asks for instant 0; its step begins when it is shown;
 * - a shown instant's step lasts 1 / instantsPerSecond seconds; then the next instant is asked
 *   for (after the last: instant 0 again when looping, else the animation has Ended and keeps the
 *   last instant);
 * - until the asked instant is shown the animation Holds (once the clock has moved on since it
 *   was asked for): the displayed time stays (no instant is ever skipped, no frame mixes two
 *   times). When it arrives within one step of its due time
 *   the schedule is kept (steps begin at start + k / rate, so a render at any frame rate shows
 *   instant k from frame time k / rate on); later than that the schedule restarts from its
 *   arrival (the instant gets its whole step);
 * - at most one step per update: at a rate above the frame rate the animation plays one instant
 *   per frame.
 *
 * With `tellus render --wait-complete` every frame waits for its swap, so an update never finds
 * its target missing: the instant of frame n is a function of n alone (deterministic frames).
 * ahead(k) names the k instants after the target, in playing order: what is fetched ahead
 * (TimePrefetch.hpp).
 */

#include <cstddef>
#include <cstdint>
#include <expected>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct TimeAnimationOptions {
  double instantsPerSecond = 1.0; ///< (0, 1000]
  bool loop = true;               ///< after the last instant the first again; else it ends there
  /** Instants after the one asked for whose tiles are fetched ahead (at low priority, bounded:
   * TimePrefetch.hpp); [0, 16]. */
  std::size_t fetchAhead = 2;
  /** Tile requests out at once for the times ahead (>= 1): the bound on what fetching ahead
   * has in flight (that many tiles' bytes). */
  std::size_t aheadInFlight = 4;
};

enum class PlayState : std::uint8_t {
  Playing, ///< the asked instant is shown, its step runs
  Holding, ///< the asked instant's tiles are not all there: the shown time stays
  Paused,
  Ended, ///< not looping, the last instant shown and its step over
};

/** "playing", "holding", "paused", "ended". */
const char* playStateName(PlayState s) noexcept;

class TimeAnimation {
public:
  /** A non-empty list of distinct, non-empty instants and options in range; else why not. */
  static std::expected<TimeAnimation, std::string> create(std::vector<std::string> instants,
                                                          TimeAnimationOptions options);

  /** One frame (see the file comment): observe(), then the next instant asked for when the
   * shown one's step is over; returns target(). */
  const std::string& update(double nowS, std::string_view shown);
  /** The time the layer shows at nowS (after a frame's swaps): whether the target arrived. */
  void observe(double nowS, std::string_view shown);
  /** Plays from now: the shown instant gets a whole step from nowS; an Ended one starts over. */
  void play(double nowS);
  void pause() noexcept;
  /** Pause, or play from nowS. */
  void togglePause(double nowS);
  /** By hand: the instant `delta` steps from the target (wrapping round the list), paused. */
  void step(int delta);

  const std::string& target() const noexcept { return instants_[target_]; }
  std::size_t targetIndex() const noexcept { return target_; }
  /** The k instants after the target in playing order (fewer at the end when not looping, at
   * most size() - 1). */
  std::vector<std::string> ahead(std::size_t k) const;
  PlayState state() const noexcept;
  const std::vector<std::string>& instants() const noexcept { return instants_; }
  const TimeAnimationOptions& options() const noexcept { return opt_; }
  std::size_t steps() const noexcept { return steps_; } ///< instants shown after being asked for
  /** Steps whose instant was shown only after the clock had moved on from when it was asked
   * for, and the seconds they held in all (the display waited for tiles). */
  std::size_t heldSteps() const noexcept { return heldSteps_; }
  double heldSeconds() const noexcept { return heldSeconds_; }

private:
  TimeAnimation(std::vector<std::string> instants, TimeAnimationOptions options);
  void ask(std::size_t index, double dueS, double nowS);

  std::vector<std::string> instants_;
  TimeAnimationOptions opt_;
  double periodS_ = 1.0;
  bool started_ = false;
  bool paused_ = false;
  bool ended_ = false;
  std::size_t target_ = 0;
  bool shown_ = false;      ///< the target is shown
  double dueS_ = 0.0;       ///< when the target was due
  double askedAtS_ = 0.0;   ///< when it was asked for
  double lastS_ = 0.0;      ///< the clock at the last observe()
  double stepStartS_ = 0.0; ///< when the shown target's step began
  std::size_t steps_ = 0;
  std::size_t heldSteps_ = 0;
  double heldSeconds_ = 0.0;
};

} // namespace tellus::planet
