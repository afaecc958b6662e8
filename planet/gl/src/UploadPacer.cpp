#include "UploadPacer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace tellus::planet {

UploadPacer::UploadPacer(UploadPacing pacing)
    : pacing_(pacing), budgetMs_(std::numeric_limits<double>::infinity()) {
  pacing_.window = std::max<std::size_t>(1, pacing_.window);
}

void UploadPacer::recordFrame(double frameMs, double uploadMs) {
  if (!std::isfinite(frameMs) || !std::isfinite(uploadMs)) return;
  recent_.push_back(std::max(0.0, frameMs - std::max(0.0, uploadMs)));
  while (recent_.size() > pacing_.window)
    recent_.pop_front();
  if (!(pacing_.shareOfFrame > 0.0)) return;
  std::vector<double> sorted(recent_.begin(), recent_.end());
  const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  budgetMs_ = std::max(pacing_.minMs, pacing_.shareOfFrame * *mid);
}

double UploadPacer::timeBudgetMs() const {
  return budgetMs_;
}

bool UploadPacer::mayContinue(std::size_t bytes, double ms) const {
  if (bytes == 0) return true;
  return bytes < pacing_.bytesPerFrame && ms < budgetMs_;
}

std::size_t UploadPacer::bandBytes(std::size_t bytes) const {
  // Bands of at most 1 MiB, so that the time cap is looked at every millisecond or so.
  constexpr std::size_t kMaxBand = std::size_t{1} << 20;
  const std::size_t left = pacing_.bytesPerFrame > bytes ? pacing_.bytesPerFrame - bytes : 0;
  return std::max<std::size_t>(1, std::min(left, kMaxBand));
}

} // namespace tellus::planet
