// The statistics `tellus render --stats` writes (GL-free, label unit): the document to the byte
// (bench/flight_stats.py, the bench scripts and tests/cli read it), read back as JSON, strings
// escaped, the dome's error, and the frame-time summary (nearest rank).

#include <tellus/planet_gl/RenderStatsJson.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace tellus::planet {
namespace {

using Json = nlohmann::json;

FramePhases frame(double total, double update = 0.0) {
  FramePhases f;
  f.total = total;
  f.update = update;
  return f;
}

/** Every field different, so that a field written in another's place shows. */
RenderStats sampleStats() {
  RenderStats s;
  s.frames = 3;
  s.nodesVisible = 11;
  s.nodesDrawn = 12;
  s.nodesCreated = 13;
  s.nodesCreatedTotal = 14;
  s.nodesInTree = 15;
  s.maxLevel = 6;
  s.tilesRequested = 21;
  s.tilesReceived = 22;
  s.tilesAbsent = 23;
  s.tilesFailed = 24;
  s.tilesInFlight = 25;
  s.texturesDecoded = 26;
  s.decodeErrors = 27;
  s.texturesUploaded = 28;
  s.bytesReceived = 1234567;
  s.bytesUploaded = 7654321;
  s.texturesResident = 31;
  s.textureBytes = 32;
  s.texturesReused = 33;
  s.texturesEvicted = 34;
  s.updateMs = 1.23456;
  s.longestUpdateMs = 9.8765;
  s.frameMs = 16.6666;
  s.reversedZ = true;
  s.glVersion = "4.5 (Core Profile) Mesa 22.3.6, llvmpipe";
  s.heightTilesRequested = 41;
  s.heightTilesReceived = 42;
  s.heightTilesAbsent = 43;
  s.heightTilesFailed = 44;
  s.nodesWithoutHeights = 45;
  s.meshesBuilt = 46;
  s.meshesBuiltLast = 47;
  s.meshMs = 0.5;
  s.meshMsTotal = 100.0625;
  s.edgesFixed = 48;
  s.zeroAreaTriangles = 0;
  s.cameraLifted = false;
  s.domeMethod = "direct";
  s.domeErrorPx = 0.123456;
  s.domeFaceBytes = 0;
  s.passes = 2;
  s.overlaysPerPass = 4;
  s.sceneTimeUnixSeconds = 1710957600.25; // 2024-03-20T18:00:00.25Z
  s.sunlight = true;
  RenderStats::Layer base;
  base.name = "bluemarble";
  base.tilesRequested = 51;
  base.tilesReceived = 52;
  base.texturesResident = 53;
  RenderStats::Layer sst;
  sst.name = "sst";
  sst.time = "2024-01-01";
  sst.pendingTime = "2024-01-02";
  sst.opacity = 0.5;
  sst.visible = false;
  sst.swaps = 1;
  sst.night = true;
  RenderStats::Layer::Animation& a = sst.animation.emplace();
  a.state = "holding";
  a.target = "2024-01-02";
  a.instants = 12;
  a.steps = 1;
  a.heldSteps = 1;
  a.heldSeconds = 0.25;
  a.aheadRequested = 8;
  a.aheadReceived = 4;
  a.aheadInFlight = 4;
  a.aheadMaxInFlight = 4;
  a.aheadWanted = 16;
  a.aheadSettled = 4;
  s.layers = {base, sst};
  return s;
}

TEST(RenderStatsJson, TheDocumentToTheByte) {
  const std::vector<FramePhases> frames = {frame(5.0, 1.0), frame(7.25, 2.0), frame(3.0, 0.5)};
  const std::vector<double> cpu = {10.0, 12.5, 8.0};
  const std::string want = R"({
  "complete": true,
  "seconds": 1.235,
  "frames": 3,
  "nodes_visible": 11,
  "nodes_drawn": 12,
  "nodes_created": 13,
  "nodes_created_total": 14,
  "nodes_in_tree": 15,
  "max_level": 6,
  "tiles_requested": 21,
  "tiles_received": 22,
  "tiles_absent": 23,
  "tiles_failed": 24,
  "tiles_in_flight": 25,
  "textures_decoded": 26,
  "decode_errors": 27,
  "textures_uploaded": 28,
  "bytes_received": 1234567,
  "bytes_uploaded": 7654321,
  "textures_resident": 31,
  "texture_bytes": 32,
  "textures_reused": 33,
  "textures_evicted": 34,
  "update_ms": 1.235,
  "longest_update_ms": 9.877,
  "frame_ms": 16.667,
  "reversed_z": true,
  "gl": "4.5 (Core Profile) Mesa 22.3.6, llvmpipe",
  "height_tiles_requested": 41,
  "height_tiles_received": 42,
  "height_tiles_absent": 43,
  "height_tiles_failed": 44,
  "nodes_without_heights": 45,
  "meshes_built": 46,
  "meshes_built_last": 47,
  "mesh_ms": 0.500,
  "mesh_ms_total": 100.062,
  "edges_fixed": 48,
  "zero_area_triangles": 0,
  "camera_lifted": false,
  "dome_method": "direct",
  "dome_error_px": 0.1235,
  "dome_face_bytes": 0,
  "dome_error": "",
  "passes": 2,
  "overlays_per_pass": 4,
  "scene_time": "2024-03-20T18:00:00Z",
  "scene_time_unix": 1710957600.250,
  "sunlight": true,
  "layers": [
    {"name": "bluemarble", "time": "", "pending_time": "", "opacity": 1.000, "visible": true, "night": false, "tiles_requested": 51, "tiles_received": 52, "textures_resident": 53, "swaps": 0, "animation": null},
    {"name": "sst", "time": "2024-01-01", "pending_time": "2024-01-02", "opacity": 0.500, "visible": false, "night": true, "tiles_requested": 0, "tiles_received": 0, "textures_resident": 0, "swaps": 1, "animation": {"state": "holding", "target": "2024-01-02", "times": 12, "steps": 1, "held_steps": 1, "held_seconds": 0.250, "ahead_requested": 8, "ahead_received": 4, "ahead_in_flight": 4, "ahead_max_in_flight": 4, "ahead_wanted": 16, "ahead_settled": 4}}
  ],
  "median_frame_ms": 5.000,
  "p95_frame_ms": 7.250,
  "p99_frame_ms": 7.250,
  "longest_frame_ms": 7.250,
  "longest_frame": {"index": 1, "update_ms": 2.000, "intake_ms": 0.000, "upload_ms": 0.000, "upload_bytes": 0, "mesh_ms": 0.000, "meshes_created": 0, "draw_ms": 0.000, "finish_ms": 0.000},
  "frame_times_ms": [5.000, 7.250, 3.000],
  "update_times_ms": [1.000, 2.000, 0.500],
  "frame_cpu_ms": [10.000, 12.500, 8.000]
}
)";
  EXPECT_EQ(renderStatsJson(sampleStats(), {1.2346, true, frames, cpu, {}, {}}), want);
}

TEST(RenderStatsJson, ReadsBackAsJson) {
  const std::vector<FramePhases> frames = {frame(5.0), frame(7.25)};
  const std::vector<double> cpu = {1.0, 2.0};
  const Json j = Json::parse(renderStatsJson(sampleStats(), {3.0, false, frames, cpu, {}, {}}),
                             nullptr,
                             /*allow_exceptions=*/false);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_EQ(j["complete"], false);
  EXPECT_EQ(j["tiles_received"], 22);
  EXPECT_EQ(j["bytes_uploaded"], 7654321);
  EXPECT_EQ(j["layers"].size(), 2u);
  EXPECT_EQ(j["layers"][1]["pending_time"], "2024-01-02");
  EXPECT_EQ(j["frame_times_ms"], Json::array({5.0, 7.25}));
  EXPECT_EQ(j["frame_cpu_ms"], Json::array({1.0, 2.0}));
  EXPECT_EQ(j["longest_frame"]["index"], 1);
  EXPECT_EQ(j["scene_time"], "2024-03-20T18:00:00Z");
  EXPECT_EQ(j["layers"][1]["night"], true);
  EXPECT_TRUE(j["layers"][0]["animation"].is_null());
  EXPECT_EQ(j["layers"][1]["animation"]["state"], "holding");
  EXPECT_EQ(j.size(), 58u); // every member, none twice
  // A flight between bodies (issue 26): the body orbited at the end and where it changed.
  const std::vector<OrbitSwitch> switches = {{3, "moon"}, {9, "earth"}};
  const Json f = Json::parse(
      renderStatsJson(sampleStats(), {3.0, false, frames, cpu, "earth", switches}), nullptr, false);
  ASSERT_FALSE(f.is_discarded());
  EXPECT_EQ(f["body"], "earth");
  EXPECT_EQ(f["orbit_switches"],
            Json::parse(R"([{"frame": 3, "body": "moon"}, {"frame": 9, "body": "earth"}])"));
  EXPECT_EQ(f.size(), 60u);
}

TEST(RenderStatsJson, StringsAreEscapedAndInvalidUtf8Replaced) {
  RenderStats s;
  s.glVersion = "say \"hi\"\\ \n\t\x01 caf\xc3\xa9 \xff";
  s.domeError = "cube faces: GL_OUT_OF_MEMORY";
  s.layers.push_back({});
  s.layers.back().name = "a\"b";
  const Json j = Json::parse(renderStatsJson(s, {}), nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_EQ(j["gl"], "say \"hi\"\\ \n\t\x01 caf\xc3\xa9 \xef\xbf\xbd");
  EXPECT_EQ(j["dome_error"], "cube faces: GL_OUT_OF_MEMORY");
  EXPECT_EQ(j["layers"][0]["name"], "a\"b");
  EXPECT_TRUE(j["scene_time"].is_null()) << "no time: null, not a made-up one";
  EXPECT_TRUE(j["scene_time_unix"].is_null());
}

TEST(RenderStatsJson, DomeErrorHasFourDigitsAndIsNullWhenInfinite) {
  RenderStats s;
  const auto member = [&](double v) {
    s.domeErrorPx = v;
    const std::string json = renderStatsJson(s, {});
    const auto at = json.find("\"dome_error_px\": ");
    return json.substr(at + 17, json.find(',', at) - at - 17);
  };
  EXPECT_EQ(member(0.0), "0");
  EXPECT_EQ(member(0.123456), "0.1235");
  EXPECT_EQ(member(2.5), "2.5");
  EXPECT_EQ(member(12345.6), "1.235e+04");
  EXPECT_EQ(member(std::numeric_limits<double>::infinity()), "null");
  EXPECT_FALSE(Json::parse(renderStatsJson(s, {}), nullptr, false).is_discarded());
}

TEST(RenderStatsJson, NoFramesAndNoLayers) {
  const std::string json = renderStatsJson(RenderStats{}, {});
  EXPECT_NE(json.find("\n  \"layers\": [\n  ],\n"), std::string::npos) << json;
  EXPECT_NE(json.find("\n  \"frame_times_ms\": [],\n"), std::string::npos) << json;
  EXPECT_NE(json.find("\n  \"median_frame_ms\": 0.000,\n"), std::string::npos) << json;
  EXPECT_TRUE(json.ends_with("\n  \"frame_cpu_ms\": []\n}\n")) << json;
  const Json j = Json::parse(json, nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_EQ(j["longest_frame"]["index"], 0);
}

TEST(RenderStatsJson, FrameTimesByNearestRank) {
  const FrameTimeSummary none = summarizeFrameTimes({});
  EXPECT_EQ(none.medianMs, 0.0);
  EXPECT_EQ(none.p99Ms, 0.0);
  EXPECT_EQ(none.longestMs, 0.0);

  const std::vector<FramePhases> one = {frame(4.0)};
  const FrameTimeSummary single = summarizeFrameTimes(one);
  EXPECT_EQ(single.medianMs, 4.0);
  EXPECT_EQ(single.p95Ms, 4.0);
  EXPECT_EQ(single.longestIndex, 0u);

  // 1..20 ms shuffled: the 95th percentile is the 19th value, the 99th the 20th, the median the
  // upper of the middle two.
  std::vector<FramePhases> twenty;
  for (int i = 0; i < 20; ++i)
    twenty.push_back(frame((i * 7) % 20 + 1.0, i));
  const FrameTimeSummary t = summarizeFrameTimes(twenty);
  EXPECT_EQ(t.medianMs, 11.0);
  EXPECT_EQ(t.p95Ms, 19.0);
  EXPECT_EQ(t.p99Ms, 20.0);
  EXPECT_EQ(t.longestMs, 20.0);
  EXPECT_EQ(t.longestIndex, 17u); // (17 x 7) % 20 + 1 = 20
  EXPECT_EQ(t.longest.update, 17.0);

  // Equal longest frames: the first of them.
  const std::vector<FramePhases> ties = {frame(1.0), frame(3.0, 1.0), frame(3.0, 2.0)};
  EXPECT_EQ(summarizeFrameTimes(ties).longestIndex, 1u);
  EXPECT_EQ(summarizeFrameTimes(ties).longest.update, 1.0);
}

} // namespace
} // namespace tellus::planet
