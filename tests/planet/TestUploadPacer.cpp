// The upload pacing of the GL layer (GL-free, label unit): a byte cap and a time cap that follows
// the recent frames' median cost without their uploads.

#include "../../planet/gl/src/UploadPacer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>

using namespace tellus::planet;

namespace {

constexpr std::size_t kMiB = std::size_t{1} << 20;

} // namespace

TEST(UploadPacer, BeforeAnyFrameOnlyBytesLimit) {
  const UploadPacer p(UploadPacing{.bytesPerFrame = 8 * kMiB});
  EXPECT_TRUE(std::isinf(p.timeBudgetMs()));
  EXPECT_TRUE(p.mayContinue(0, 0.0));
  EXPECT_TRUE(p.mayContinue(7 * kMiB, 1000.0));
  EXPECT_FALSE(p.mayContinue(8 * kMiB, 0.0));
  EXPECT_FALSE(p.mayContinue(9 * kMiB, 0.0));
}

TEST(UploadPacer, TimeCapIsAShareOfTheMedianFrameWithoutUploads) {
  UploadPacer p(UploadPacing{.bytesPerFrame = 64 * kMiB, .shareOfFrame = 0.25, .minMs = 0.5});
  // Frames of 20 ms of which 4 ms were uploads: 16 ms without, a 4 ms cap.
  for (int i = 0; i < 5; ++i)
    p.recordFrame(20.0, 4.0);
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 4.0);
  EXPECT_TRUE(p.mayContinue(kMiB, 3.9));
  EXPECT_FALSE(p.mayContinue(kMiB, 4.0));
}

TEST(UploadPacer, OneSlowFrameDoesNotMoveTheMedian) {
  UploadPacer p(UploadPacing{.shareOfFrame = 0.5, .window = 9});
  for (int i = 0; i < 8; ++i)
    p.recordFrame(10.0, 0.0);
  p.recordFrame(500.0, 0.0); // preempted, or a view that costs more
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 5.0);
}

TEST(UploadPacer, FollowsTheRecentFramesOnly) {
  UploadPacer p(UploadPacing{.shareOfFrame = 0.5, .window = 5});
  for (int i = 0; i < 20; ++i)
    p.recordFrame(40.0, 0.0);
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 20.0);
  for (int i = 0; i < 5; ++i)
    p.recordFrame(8.0, 0.0);
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 4.0); // the old frames left the window
}

TEST(UploadPacer, FloorAndTheFirstBandAlwaysGo) {
  UploadPacer p(UploadPacing{.shareOfFrame = 0.25, .minMs = 0.5});
  for (int i = 0; i < 10; ++i)
    p.recordFrame(1.0, 0.9); // frames nearly all upload: 0.1 ms without
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 0.5);
  // However slow: the first band of a frame goes, so uploads always move.
  EXPECT_TRUE(p.mayContinue(0, 100.0));
  EXPECT_FALSE(p.mayContinue(1, 100.0));
}

TEST(UploadPacer, NoShareMeansBytesAlone) {
  UploadPacer p(UploadPacing{.bytesPerFrame = 2 * kMiB, .shareOfFrame = 0.0});
  for (int i = 0; i < 10; ++i)
    p.recordFrame(10.0, 0.0);
  EXPECT_TRUE(std::isinf(p.timeBudgetMs()));
  EXPECT_TRUE(p.mayContinue(kMiB, 1e6));
  EXPECT_FALSE(p.mayContinue(2 * kMiB, 0.0));
}

TEST(UploadPacer, IgnoresNonFiniteFrameTimes) {
  UploadPacer p(UploadPacing{.shareOfFrame = 0.5});
  p.recordFrame(10.0, 0.0);
  p.recordFrame(NAN, 0.0);
  p.recordFrame(INFINITY, 0.0);
  p.recordFrame(10.0, INFINITY);
  EXPECT_DOUBLE_EQ(p.timeBudgetMs(), 5.0);
}

TEST(UploadPacer, BandsAreAtMostAMiBAndWhatTheBytesLeave) {
  const UploadPacer p(UploadPacing{.bytesPerFrame = 3 * kMiB + 100});
  EXPECT_EQ(p.bandBytes(0), kMiB);
  EXPECT_EQ(p.bandBytes(3 * kMiB), 100u);
  EXPECT_EQ(p.bandBytes(3 * kMiB + 100), 1u); // over the cap: one row at least (the caller clamps)
  const UploadPacer small(UploadPacing{.bytesPerFrame = 64 * 1024});
  EXPECT_EQ(small.bandBytes(0), 64u * 1024u);
}
