#include <tellus/values/Legend.hpp>

#include <cmath>

namespace tellus::values {

namespace {

std::vector<double> linearTicks(double min, double max, int maxTicks) {
  const double span = max - min;
  int k = static_cast<int>(std::floor(std::log10(span / maxTicks))) - 1;
  for (;; ++k)
    for (const double m : {1.0, 2.0, 5.0}) {
      const double step = m * std::pow(10.0, k);
      const double first = std::ceil(min / step - 1e-9), last = std::floor(max / step + 1e-9);
      if (last - first + 1.0 > maxTicks) continue;
      std::vector<double> out;
      for (double i = first; i <= last; i += 1.0)
        out.push_back(i * step);
      return out;
    }
}

std::vector<double> logTicks(double min, double max, int maxTicks) {
  const double lo = std::log10(min), hi = std::log10(max);
  const int first = static_cast<int>(std::ceil(lo - 1e-9));
  const int last = static_cast<int>(std::floor(hi + 1e-9));
  std::vector<double> out;
  if (last - first + 1 < 3) {
    // Fewer than 3 decades: 1, 2 and 5 times each power of ten inside the range.
    for (int k = static_cast<int>(std::floor(lo)); k <= last; ++k)
      for (const double m : {1.0, 2.0, 5.0}) {
        const double v = m * std::pow(10.0, k);
        if (v >= min * (1 - 1e-12) && v <= max * (1 + 1e-12)) out.push_back(v);
      }
    if (static_cast<int>(out.size()) <= maxTicks) return out;
    out.clear();
  }
  const int count = last - first + 1;
  const int every = std::max(1, (count + maxTicks - 1) / maxTicks);
  for (int k = first; k <= last; ++k)
    if ((k - first) % every == 0) out.push_back(std::pow(10.0, k));
  return out;
}

} // namespace

std::vector<double> legendTicks(double min, double max, Scaling scaling, int maxTicks) {
  if (!(min < max) || !std::isfinite(min) || !std::isfinite(max)) return {};
  maxTicks = std::max(maxTicks, 2);
  if (scaling == Scaling::Log) {
    if (min <= 0.0) return {};
    return logTicks(min, max, maxTicks);
  }
  return linearTicks(min, max, maxTicks);
}

} // namespace tellus::values
