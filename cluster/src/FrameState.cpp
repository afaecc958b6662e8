#include <tellus/cluster/FrameState.hpp>

#include <cstdio>
#include <cstring>

namespace tellus::cluster {
namespace {

template <typename T> void mix(std::uint64_t& h, const T& value) noexcept {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (const unsigned char b : bytes) {
    h ^= b;
    h *= 0x100000001b3ull;
  }
}

} // namespace

std::uint64_t digest(const FrameState& s) noexcept {
  std::uint64_t h = 0xcbf29ce484222325ull;
  mix(h, s.frame);
  for (const double v :
       {s.latDeg, s.lonDeg, s.altitudeM, s.headingDeg, s.tiltDeg, s.sceneTimeUnixS})
    mix(h, v);
  mix(h, s.hasSceneTime);
  mix(h, s.layerTimesAtS);
  mix(h, s.hasLayerTimes);
  mix(h, s.body);
  for (int i = 0; i < kFrameLayers; ++i) {
    mix(h, s.layerOpacity[i]);
    mix(h, s.layerTime[i]);
    mix(h, s.layerVisible[i]);
  }
  return h;
}

std::string digestLine(const FrameState& s) {
  char line[64];
  std::snprintf(line,
                sizeof line,
                "%lld %016llx\n",
                static_cast<long long>(s.frame),
                static_cast<unsigned long long>(digest(s)));
  return line;
}

} // namespace tellus::cluster
