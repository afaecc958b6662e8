#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet_gl/RenderStatsJson.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus::planet {
namespace {

/** "%.3f": milliseconds (and seconds) to the microsecond. */
std::string fixed3(double v) {
  char buf[400]; // the longest double printed with three decimals is 313 characters
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

std::string number(std::size_t v) {
  return std::to_string(v);
}
std::string boolean(bool v) {
  return v ? "true" : "false";
}

/** A JSON string: escaped by nlohmann-json, invalid UTF-8 replaced rather than thrown at. */
std::string jsonString(std::string_view s) {
  return nlohmann::json(std::string(s))
      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

using Members = std::initializer_list<std::pair<std::string_view, std::string>>;

/** {"a": 1, "b": 2} on one line. */
std::string inlineObject(Members members) {
  std::string out = "{";
  for (const auto& [key, value] : members) {
    if (out.size() > 1) out += ", ";
    out += jsonString(key) + ": " + value;
  }
  return out + "}";
}

/** [1.000, 2.000] on one line. */
std::string inlineArray(const std::vector<double>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i)
    out += (i == 0 ? "" : ", ") + fixed3(values[i]);
  return out + "]";
}

/** The top-level object, one member per line indented by two spaces. */
class Document {
public:
  void add(std::string_view key, const std::string& value) {
    out_ += out_.empty() ? "{\n  " : ",\n  ";
    out_ += jsonString(key) + ": " + value;
  }
  void add(Members members) {
    for (const auto& [key, value] : members)
      add(key, value);
  }
  std::string finish() && { return std::move(out_) + "\n}\n"; }

private:
  std::string out_;
};

void addCounters(Document& doc, const RenderStats& s, const RenderRun& run) {
  doc.add({{"complete", boolean(run.complete)},
           {"seconds", fixed3(run.seconds)},
           {"frames", std::to_string(s.frames)},
           {"nodes_visible", number(s.nodesVisible)},
           {"nodes_drawn", number(s.nodesDrawn)},
           {"nodes_created", number(s.nodesCreated)},
           {"nodes_created_total", number(s.nodesCreatedTotal)},
           {"nodes_in_tree", number(s.nodesInTree)},
           {"max_level", std::to_string(s.maxLevel)},
           {"tiles_requested", number(s.tilesRequested)},
           {"tiles_received", number(s.tilesReceived)},
           {"tiles_absent", number(s.tilesAbsent)},
           {"tiles_failed", number(s.tilesFailed)},
           {"tiles_in_flight", number(s.tilesInFlight)},
           {"textures_decoded", number(s.texturesDecoded)},
           {"decode_errors", number(s.decodeErrors)},
           {"textures_uploaded", number(s.texturesUploaded)},
           {"bytes_received", number(s.bytesReceived)},
           {"bytes_uploaded", number(s.bytesUploaded)},
           {"textures_resident", number(s.texturesResident)},
           {"texture_bytes", number(s.textureBytes)},
           {"textures_reused", number(s.texturesReused)},
           {"textures_evicted", number(s.texturesEvicted)},
           {"update_ms", fixed3(s.updateMs)},
           {"longest_update_ms", fixed3(s.longestUpdateMs)},
           {"frame_ms", fixed3(s.frameMs)},
           {"reversed_z", boolean(s.reversedZ)},
           {"gl", jsonString(s.glVersion)}});
  if (s.atmospherePrecomputeMs > 0.0)
    doc.add({{"atmosphere_precompute_ms", fixed3(s.atmospherePrecomputeMs)}});
}

void addTerrain(Document& doc, const RenderStats& s) {
  doc.add({{"height_tiles_requested", number(s.heightTilesRequested)},
           {"height_tiles_received", number(s.heightTilesReceived)},
           {"height_tiles_absent", number(s.heightTilesAbsent)},
           {"height_tiles_failed", number(s.heightTilesFailed)},
           {"nodes_without_heights", number(s.nodesWithoutHeights)},
           {"meshes_built", number(s.meshesBuilt)},
           {"meshes_built_last", number(s.meshesBuiltLast)},
           {"mesh_ms", fixed3(s.meshMs)},
           {"mesh_ms_total", fixed3(s.meshMsTotal)},
           {"edges_fixed", number(s.edgesFixed)},
           {"zero_area_triangles", number(s.zeroAreaTriangles)},
           {"camera_lifted", boolean(s.cameraLifted)}});
}

/** Time that plays (issue 24): null for a layer that is not animated. */
std::string animationJson(const std::optional<RenderStats::Layer::Animation>& a) {
  if (!a) return "null";
  return inlineObject({{"state", jsonString(a->state)},
                       {"target", jsonString(a->target)},
                       {"times", number(a->instants)},
                       {"steps", number(a->steps)},
                       {"held_steps", number(a->heldSteps)},
                       {"held_seconds", fixed3(a->heldSeconds)},
                       {"ahead_requested", number(a->aheadRequested)},
                       {"ahead_received", number(a->aheadReceived)},
                       {"ahead_in_flight", number(a->aheadInFlight)},
                       {"ahead_max_in_flight", number(a->aheadMaxInFlight)},
                       {"ahead_wanted", number(a->aheadWanted)},
                       {"ahead_settled", number(a->aheadSettled)}});
}

/** The dome (issue #7): how the last frame was drawn and the direct method's error estimate; the
 * layers: the base, then the overlays in drawing order, one per line. */
void addDomeAndLayers(Document& doc, const RenderStats& s) {
  std::string errorPx = "null"; // infinite: an edge that cannot be mapped
  if (std::isfinite(s.domeErrorPx)) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", s.domeErrorPx);
    errorPx = buf;
  }
  doc.add({{"dome_method", jsonString(s.domeMethod)},
           {"dome_error_px", errorPx},
           {"dome_face_bytes", number(s.domeFaceBytes)},
           {"dome_error", jsonString(s.domeError)},
           {"passes", std::to_string(s.passes)},
           {"overlays_per_pass", std::to_string(s.overlaysPerPass)},
           // The scene's time the last frame was drawn at (issue 23): null when none.
           {"scene_time",
            s.sceneTimeUnixSeconds ? jsonString(formatSceneTime(*s.sceneTimeUnixSeconds))
                                   : std::string("null")},
           {"scene_time_unix",
            s.sceneTimeUnixSeconds ? fixed3(*s.sceneTimeUnixSeconds) : std::string("null")},
           {"sunlight", boolean(s.sunlight)}});
  std::string layers = "[";
  for (std::size_t i = 0; i < s.layers.size(); ++i) {
    const RenderStats::Layer& l = s.layers[i];
    layers += i == 0 ? "\n    " : ",\n    ";
    layers += inlineObject({{"name", jsonString(l.name)},
                            {"time", jsonString(l.time)},
                            {"pending_time", jsonString(l.pendingTime)},
                            {"opacity", fixed3(l.opacity)},
                            {"visible", boolean(l.visible)},
                            {"night", boolean(l.night)},
                            {"tiles_requested", number(l.tilesRequested)},
                            {"tiles_received", number(l.tilesReceived)},
                            {"textures_resident", number(l.texturesResident)},
                            {"swaps", number(l.swaps)},
                            {"animation", animationJson(l.animation)}});
  }
  doc.add("layers", layers + "\n  ]");
}

/** The frame times: their summary, then every frame's time, update time and CPU time in order. */
void addFrameTimes(Document& doc, const RenderRun& run) {
  const FrameTimeSummary f = summarizeFrameTimes(run.frames);
  const FramePhases& w = f.longest;
  doc.add({{"median_frame_ms", fixed3(f.medianMs)},
           {"p95_frame_ms", fixed3(f.p95Ms)},
           {"p99_frame_ms", fixed3(f.p99Ms)},
           {"longest_frame_ms", fixed3(f.longestMs)},
           {"longest_frame",
            inlineObject({{"index", number(f.longestIndex)},
                          {"update_ms", fixed3(w.update)},
                          {"intake_ms", fixed3(w.intake)},
                          {"upload_ms", fixed3(w.upload)},
                          {"upload_bytes", number(w.uploadBytes)},
                          {"mesh_ms", fixed3(w.mesh)},
                          {"meshes_created", number(w.meshesCreated)},
                          {"draw_ms", fixed3(w.draw)},
                          {"finish_ms", fixed3(w.finish)}})}});
  std::vector<double> totals, updates;
  for (const FramePhases& p : run.frames) {
    totals.push_back(p.total);
    updates.push_back(p.update);
  }
  doc.add({{"frame_times_ms", inlineArray(totals)},
           {"update_times_ms", inlineArray(updates)},
           {"frame_cpu_ms", inlineArray({run.frameCpuMs.begin(), run.frameCpuMs.end()})}});
}

} // namespace

FrameTimeSummary summarizeFrameTimes(std::span<const FramePhases> frames) {
  FrameTimeSummary out;
  std::vector<double> sorted;
  sorted.reserve(frames.size());
  for (const FramePhases& f : frames)
    sorted.push_back(f.total);
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (frames[i].total > out.longest.total) {
      out.longest = frames[i];
      out.longestIndex = i;
    }
  if (sorted.empty()) return out;
  const auto rank = [&](double q) {
    const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
    return sorted[std::clamp<std::size_t>(i, 1, sorted.size()) - 1];
  };
  out.medianMs = sorted[sorted.size() / 2];
  out.p95Ms = rank(0.95);
  out.p99Ms = rank(0.99);
  out.longestMs = sorted.back();
  return out;
}

std::string renderStatsJson(const RenderStats& stats, const RenderRun& run) {
  Document doc;
  addCounters(doc, stats, run);
  addTerrain(doc, stats);
  addDomeAndLayers(doc, stats);
  addFrameTimes(doc, run);
  if (!run.body.empty()) {
    std::string switches = "[";
    for (const OrbitSwitch& o : run.orbitSwitches)
      switches += (switches.size() > 1 ? ", " : "") +
                  inlineObject({{"frame", number(o.frame)}, {"body", jsonString(o.body)}});
    doc.add({{"body", jsonString(run.body)}, {"orbit_switches", switches + "]"}});
  }
  return std::move(doc).finish();
}

} // namespace tellus::planet
