#pragma once
/**
 * @file SceneTime.hpp
 * @brief The scene's time as people write it and as a viewer runs it (issue 23): ISO 8601 UTC
 * instants in and out, and SceneClock, the scene's time driven by a wall clock at a rate that can
 * be sped up, slowed, reversed and paused.
 *
 * Times are UTC as POSIX seconds (double; leap seconds not counted), the unit of Astronomy.hpp.
 *
 * Accepted forms (parseSceneTime): every ISO 8601 instant cache/IsoTime.hpp reads (the one
 * reader of the configuration, the WMS TIME dimension and the scene: "YYYY-MM-DDThh:mm[:ss[.fff]]"
 * with 'Z', an offset such as +02:00 (converted to UTC) or no zone (UTC), "YYYY-MM-DD" (00:00
 * UTC), years 0000-9999 in the proleptic Gregorian calendar), and "now" (the wall clock's now,
 * given by the caller so that tests fix it).
 *
 * Pure functions; SceneClock is a value, used from one thread.
 */

#include <expected>
#include <string>
#include <string_view>

namespace tellus::planet {

/** An ISO 8601 UTC instant (see the file comment) as POSIX seconds; "now" gives nowUnixSeconds.
 * Else why not ("expected YYYY-MM-DDThh:mm:ssZ or now, got '...'"). */
std::expected<double, std::string> parseSceneTime(std::string_view text, double nowUnixSeconds);
/** POSIX seconds as "YYYY-MM-DDThh:mm:ssZ" (rounded down to the second; years outside
 * 0001-9999 come out as "+-N s" POSIX seconds instead). */
std::string formatSceneTime(double unixSeconds);

/** The scene's time in a viewer: advances with the wall clock times a rate (1 = real time;
 * negative runs backwards; 0 with paused). faster()/slower() step the rate's size through
 * 1, 10, 60, 600, 3600, 86400 (and down to 1; real time is the slowest running rate), reverse()
 * flips its sign, togglePause() stops and restarts it without losing the rate. */
class SceneClock {
public:
  /** The scene at `startUnixSeconds` at wall time `wallSeconds` (any origin, e.g. steady). */
  SceneClock(double startUnixSeconds, double wallSeconds) noexcept
      : time_(startUnixSeconds), wall_(wallSeconds) {}
  /** The scene's time at this wall time (later than the last call: earlier ones count as 0). */
  double advance(double wallSeconds) noexcept;
  double time() const noexcept { return time_; }
  /** Scene seconds per wall second, 0 while paused. */
  double rate() const noexcept { return paused_ ? 0.0 : rate_; }
  bool paused() const noexcept { return paused_; }
  void faster() noexcept;
  void slower() noexcept;
  void reverse() noexcept { rate_ = -rate_; }
  void togglePause() noexcept { paused_ = !paused_; }
  /** Jumps the scene to a time (the rate kept). */
  void set(double unixSeconds) noexcept { time_ = unixSeconds; }

private:
  double time_;
  double wall_;
  double rate_ = 1.0;
  bool paused_ = false;
};

} // namespace tellus::planet
