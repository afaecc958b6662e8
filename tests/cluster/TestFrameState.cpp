// The cluster's frame state (issue 28): its digest, which the frame-lock test compares between
// ranks, tells equal states apart from any changed field.
#include <tellus/cluster/FrameState.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <type_traits>

using tellus::cluster::FrameState;

TEST(FrameState, DigestSeesEveryField) {
  FrameState s;
  s.frame = 7;
  s.setPose({45.0, 7.0, 1.5e6, 10.0, 20.0});
  s.sceneTimeUnixS = 1.7e9;
  s.hasSceneTime = 1;
  s.layerTimesAtS = 2.5;
  s.hasLayerTimes = 1;
  const FrameState copy = s;
  EXPECT_EQ(digest(copy), digest(s));
  std::set<std::uint64_t> seen{digest(s)};
  for (int field = 0; field < 14; ++field) {
    FrameState t = s;
    switch (field) {
    case 0:
      t.frame = 8;
      break;
    case 1:
      t.latDeg = std::nextafter(t.latDeg, 90.0);
      break;
    case 2:
      t.lonDeg += 1e-9;
      break;
    case 3:
      t.altitudeM += 1e-3;
      break;
    case 4:
      t.headingDeg = -t.headingDeg;
      break;
    case 5:
      t.tiltDeg = 0.0;
      break;
    case 6:
      t.sceneTimeUnixS += 1.0;
      break;
    case 7:
      t.hasSceneTime = 0;
      break;
    case 8:
      t.layerTimesAtS = 2.0;
      break;
    case 9:
      t.hasLayerTimes = 0;
      break;
    case 10:
      t.body = 1;
      break;
    case 11:
      t.layerOpacity[7] = 0.5f;
      break;
    case 12:
      t.layerTime[1] = 3;
      break;
    default:
      t.layerVisible[2] = 0;
      break;
    }
    EXPECT_TRUE(seen.insert(digest(t)).second) << "field " << field;
  }
  EXPECT_EQ(s.pose().altitudeM, 1.5e6);
  EXPECT_EQ(tellus::cluster::digestLine(s).substr(0, 2), "7 ");
  EXPECT_EQ(tellus::cluster::digestLine(s).size(), 2u + 16u + 1u);
}

// ranksLost tells the ranks at the end of a show not to finalize MPI; it is no part of what is
// drawn, so not of the digest.
TEST(FrameState, DigestLeavesRanksLostOut) {
  FrameState s;
  s.frame = -1;
  FrameState t = s;
  t.ranksLost = 1;
  EXPECT_EQ(digest(s), digest(t));
}

// The state goes over the wire as bytes (MPI_BYTE): a POD of fixed size, no hidden padding.
static_assert(std::is_trivially_copyable_v<FrameState>);
static_assert(sizeof(FrameState) == 8 + 6 * 8 + 4 + 4 + 8 + 4 + 4 + 8 * (4 + 4 + 1));
