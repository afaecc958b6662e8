#include <tellus/planet/TimeAnimation.hpp>

#include <algorithm>
#include <cmath>
#include <unordered_set>
#include <utility>

namespace tellus::planet {

const char* playStateName(PlayState s) noexcept {
  switch (s) {
  case PlayState::Playing:
    return "playing";
  case PlayState::Holding:
    return "holding";
  case PlayState::Paused:
    return "paused";
  case PlayState::Ended:
    return "ended";
  }
  return "?";
}

std::expected<TimeAnimation, std::string> TimeAnimation::create(std::vector<std::string> instants,
                                                                TimeAnimationOptions options) {
  if (instants.empty()) return std::unexpected(std::string("an animation needs at least one time"));
  std::unordered_set<std::string> seen;
  for (const std::string& t : instants) {
    if (t.empty()) return std::unexpected(std::string("an animation's time is empty"));
    if (!seen.insert(t).second)
      return std::unexpected("an animation names the time " + t + " twice");
  }
  if (!(options.instantsPerSecond > 0.0 && options.instantsPerSecond <= 1000.0))
    return std::unexpected(std::string("the rate must be in (0, 1000] times a second"));
  if (options.fetchAhead > 16)
    return std::unexpected(std::string("fetching ahead takes 0 to 16 times"));
  if (options.aheadInFlight < 1 || options.aheadInFlight > 64)
    return std::unexpected(std::string("fetching ahead keeps 1 to 64 tiles in flight"));
  return TimeAnimation(std::move(instants), options);
}

TimeAnimation::TimeAnimation(std::vector<std::string> instants, TimeAnimationOptions options)
    : instants_(std::move(instants)), opt_(options), periodS_(1.0 / options.instantsPerSecond) {}

void TimeAnimation::ask(std::size_t index, double dueS, double nowS) {
  target_ = index;
  dueS_ = dueS;
  askedAtS_ = nowS;
  shown_ = false;
}

void TimeAnimation::observe(double nowS, std::string_view shown) {
  if (!started_) return;
  lastS_ = nowS;
  if (shown_ || shown != instants_[target_]) return;
  shown_ = true;
  ++steps_;
  if (nowS > askedAtS_) { // frames were drawn with the old time while this one's tiles came
    ++heldSteps_;
    heldSeconds_ += nowS - askedAtS_;
  }
  // Within a step of its due time the schedule holds; later, the instant gets a whole step.
  stepStartS_ = nowS - dueS_ <= periodS_ ? dueS_ : nowS;
}

const std::string& TimeAnimation::update(double nowS, std::string_view shown) {
  if (!started_) {
    started_ = true;
    ask(0, nowS, nowS);
  }
  observe(nowS, shown);
  if (!shown_ || paused_ || ended_ || nowS < stepStartS_ + periodS_) return target();
  const double due = stepStartS_ + periodS_;
  if (target_ + 1 < instants_.size()) {
    ask(target_ + 1, due, nowS);
  } else if (opt_.loop && instants_.size() > 1) {
    ask(0, due, nowS);
  } else {
    ended_ = true;
  }
  return target();
}

void TimeAnimation::play(double nowS) {
  paused_ = false;
  if (ended_) {
    ended_ = false;
    if (started_) ask(0, nowS, nowS);
  }
  if (shown_) stepStartS_ = nowS;
  dueS_ = nowS;
  askedAtS_ = std::max(askedAtS_, nowS);
}

void TimeAnimation::pause() noexcept {
  paused_ = true;
}

void TimeAnimation::togglePause(double nowS) {
  if (paused_ || ended_)
    play(nowS);
  else
    pause();
}

void TimeAnimation::step(int delta) {
  paused_ = true;
  ended_ = false;
  started_ = true;
  const auto n = static_cast<std::int64_t>(instants_.size());
  const std::int64_t to = ((static_cast<std::int64_t>(target_) + delta) % n + n) % n;
  if (static_cast<std::size_t>(to) != target_) ask(static_cast<std::size_t>(to), lastS_, lastS_);
}

std::vector<std::string> TimeAnimation::ahead(std::size_t k) const {
  std::vector<std::string> out;
  const std::size_t n = instants_.size();
  for (std::size_t i = 1; i <= k && i < n; ++i) {
    const std::size_t at = target_ + i;
    if (at >= n && !opt_.loop) break;
    out.push_back(instants_[at % n]);
  }
  return out;
}

PlayState TimeAnimation::state() const noexcept {
  if (paused_) return PlayState::Paused;
  if (ended_) return PlayState::Ended;
  if (started_ && !shown_ && lastS_ > askedAtS_) return PlayState::Holding;
  return PlayState::Playing;
}

} // namespace tellus::planet
