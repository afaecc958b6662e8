#pragma once
/**
 * @file FrameState.hpp
 * @brief What the master of a cluster (issue 28, docs/design/cluster.md) broadcasts each frame:
 * the frame's number, the camera's pose, the scene's time and where along --path the layer times
 * are taken, a small POD that every channel
 * draws from; and its digest, which every rank writes per frame so that a test can check that
 * all ranks drew the same state for the same frame (frame lock). MPI-free.
 */

#include <tellus/planet/Camera.hpp>

#include <cstdint>
#include <string>

namespace tellus::cluster {

/** The layers a frame's state carries (the base and seven overlays). */
inline constexpr int kFrameLayers = 8;

struct FrameState {
  std::int64_t frame = 0; ///< 0, 1, ...; -1: the show is over (the channels stop)
  double latDeg = 0.0;    ///< the camera's pose (planet::CameraPose), in double
  double lonDeg = 0.0;
  double altitudeM = 0.0;
  double headingDeg = 0.0;
  double tiltDeg = 0.0;
  double sceneTimeUnixS = 0.0; ///< meaningful when hasSceneTime
  std::int32_t hasSceneTime = 0;
  /// The end of the show (frame -1) only: 1 when a rank of the job died, so that no rank calls
  /// MPI_Finalize (Open MPI 4.1's waits for the dead one); 0 otherwise (also: no uninitialised
  /// padding goes over the wire). Not in the digest.
  std::int32_t ranksLost = 0;
  /// The layer times in effect are those of --path's keyframes at this time along it
  /// (planet::FlightPath::layerTimesAt): every rank read that file, so the times need not travel.
  /// Meaningful when hasLayerTimes (the show played --path's flight at least once).
  double layerTimesAtS = 0.0;
  std::int32_t hasLayerTimes = 0;
  /// The body orbited (a flight whose keyframes name bodies): an index into the bodies every rank
  /// derives from --path alike (the first body, then each other one the keyframes name); 0 the
  /// first. The pose is over that body.
  std::int32_t body = 0;
  /// The drawn layers (0 the base, then the overlays; the first kFrameLayers) as the console set
  /// them: opacity and visibility (overlays), and the time as an index into the layer's TIME
  /// values (which every rank lists from the same configuration; -1: not set by the console, the
  /// layer's own or its keyframes').
  float layerOpacity[kFrameLayers] = {1, 1, 1, 1, 1, 1, 1, 1};
  std::int32_t layerTime[kFrameLayers] = {-1, -1, -1, -1, -1, -1, -1, -1};
  std::uint8_t layerVisible[kFrameLayers] = {1, 1, 1, 1, 1, 1, 1, 1};

  planet::CameraPose pose() const noexcept {
    return {latDeg, lonDeg, altitudeM, headingDeg, tiltDeg};
  }
  void setPose(const planet::CameraPose& p) noexcept {
    latDeg = p.latDeg;
    lonDeg = p.lonDeg;
    altitudeM = p.altitudeM;
    headingDeg = p.headingDeg;
    tiltDeg = p.tiltDeg;
  }
};

/** FNV-1a (64 bits) over every field's bytes in order: equal states, equal digests; a changed bit
 * of any field changes it. */
std::uint64_t digest(const FrameState& state) noexcept;
/** "FRAME DIGEST\n" (the digest in 16 hex digits): a line of a rank's digest file. */
std::string digestLine(const FrameState& state);

} // namespace tellus::cluster
