#include <tellus/cache/IsoTime.hpp>
#include <tellus/cache/TimeRange.hpp>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <set>
#include <utility>

namespace tellus::iso8601 {

namespace {

std::string shortened(std::string_view s) {
  if (s.size() <= 60) return std::string(s);
  return std::string(s.substr(0, 60)) + "...";
}

/** Collects instants in order, without duplicates, up to a cap. */
class Collector {
public:
  explicit Collector(std::size_t max) : max_(max) {}
  /** False once past the cap. */
  bool add(std::int64_t seconds, std::string text) {
    if (!seen_.insert(seconds).second) return true;
    if (out_.size() >= max_) {
      over_ = true;
      return false;
    }
    out_.push_back(std::move(text));
    return true;
  }
  bool over() const noexcept { return over_; }
  /** The cap: a period longer than it makes the collector go over, whatever came before. */
  std::size_t cap() const noexcept { return max_; }
  std::vector<std::string> take() { return std::move(out_); }

private:
  std::size_t max_;
  bool over_ = false;
  std::set<std::int64_t> seen_;
  std::vector<std::string> out_;
};

std::optional<Instant> wholeInstant(std::string_view s) {
  auto i = parseInstant(s);
  if (!i || i->fraction != 0.0) return std::nullopt;
  return i;
}

/** One item; a message when it is not one. */
std::expected<void, std::string>
expandItem(std::string_view item, std::span<const std::string> declared, Collector& out) {
  const auto bad = [&](const std::string& why) {
    return std::unexpected("TIME '" + shortened(item) + "' " + why);
  };
  const auto s1 = item.find('/');
  if (s1 == std::string_view::npos) {
    const auto t = wholeInstant(item);
    if (!t)
      return bad("is no ISO 8601 instant (whole seconds, e.g. 2024-01-01 or "
                 "2024-01-01T06:00:00Z)");
    out.add(t->seconds, std::string(item));
    return {};
  }
  const auto s2 = item.find('/', s1 + 1);
  if (s2 != std::string_view::npos && item.find('/', s2 + 1) != std::string_view::npos)
    return bad("has more than two '/' (write A/B/P or A/B)");
  const auto a = wholeInstant(item.substr(0, s1));
  const auto b = wholeInstant(item.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1));
  if (!a) return bad("has a bad start (an ISO 8601 instant in whole seconds)");
  if (!b) return bad("has a bad end (an ISO 8601 instant in whole seconds)");
  if (b->seconds < a->seconds) return bad("ends before it starts: an empty range");
  if (s2 == std::string_view::npos) { // A/B: the declared instants within it
    if (declared.empty())
      return bad("has no period and the layer lists no times: write start/end/period");
    std::vector<std::pair<std::int64_t, const std::string*>> within;
    for (const std::string& d : declared) {
      const auto t = wholeInstant(d);
      if (t && t->seconds >= a->seconds && t->seconds <= b->seconds)
        within.emplace_back(t->seconds, &d);
    }
    if (within.empty()) return bad("holds none of the layer's times");
    std::stable_sort(within.begin(), within.end(), [](const auto& x, const auto& y) {
      return x.first < y.first;
    });
    for (const auto& [t, d] : within)
      if (!out.add(t, *d)) return {};
    return {};
  }
  const auto step = parseDuration(item.substr(s2 + 1));
  if (!step) return bad("has a bad ISO 8601 duration (e.g. P1D, P1M, PT6H)");
  if (step->zero()) return bad("has a period of zero length");
  const Shape shape{a->shape.dateOnly && step->seconds == 0, true, true};
  for (const std::int64_t t : periodInstants(a->seconds, b->seconds, *step, out.cap()))
    if (!out.add(t, formatInstant(t, shape))) break;
  return {};
}

} // namespace

std::expected<std::vector<std::string>, std::string>
expandTimes(std::string_view text, std::span<const std::string> declared, std::size_t maxInstants) {
  if (text.empty()) return std::unexpected(std::string("TIME is empty"));
  Collector out(maxInstants);
  std::size_t from = 0;
  for (;;) {
    const auto comma = text.find(',', from);
    const std::string_view item =
        text.substr(from, comma == std::string_view::npos ? comma : comma - from);
    if (item.empty())
      return std::unexpected("TIME '" + shortened(text) +
                             "' has an empty item (two commas, or "
                             "a comma at an end)");
    if (auto ok = expandItem(item, declared, out); !ok) return std::unexpected(ok.error());
    if (out.over())
      return std::unexpected("TIME '" + shortened(text) + "' names more than " +
                             std::to_string(maxInstants) +
                             " instants; ask for a shorter range or a longer period");
    if (comma == std::string_view::npos) break;
    from = comma + 1;
  }
  return out.take();
}

} // namespace tellus::iso8601
