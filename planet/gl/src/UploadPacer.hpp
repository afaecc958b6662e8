#pragma once
// How much texture upload work one frame may do (GL-free, so that its unit tests need no display).
// Two caps: bytes (RendererOptions::uploadBytesPerFrame) and time, a share of the recent frames'
// median cost without their uploads, so that uploading never makes a frame much longer than its
// neighbours whatever the driver's speed. The first band of a frame always goes, so uploads keep
// moving however slow the frames are.

#include <cstddef>
#include <deque>

namespace tellus::planet {

struct UploadPacing {
  std::size_t bytesPerFrame = std::size_t{8} << 20;
  /** Upload time a frame may spend, as a share of the median of the last `window` frames' time
   * without their uploads; 0: no time cap. */
  double shareOfFrame = 0.25;
  double minMs = 0.5; ///< the time cap never goes below this
  std::size_t window = 31;
};

class UploadPacer {
public:
  explicit UploadPacer(UploadPacing pacing = {});

  /** A frame's cost: its total time and the part of it spent uploading (ms). */
  void recordFrame(double frameMs, double uploadMs);
  /** This frame's upload time cap (ms); infinite before any frame was recorded or without a
   * share. */
  double timeBudgetMs() const;
  /** Whether the frame may start another band after sending `bytes` in `ms` so far. */
  bool mayContinue(std::size_t bytes, double ms) const;
  /** Bytes the next band may carry after `bytes` so far this frame (at least 1). */
  std::size_t bandBytes(std::size_t bytes) const;

private:
  UploadPacing pacing_;
  std::deque<double> recent_; ///< frame times without uploads, oldest first
  double budgetMs_;
};

} // namespace tellus::planet
