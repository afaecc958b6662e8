// The master's control API (issue 28): requests parsed and checked, bad ones refused with their
// HTTP status and what is wrong; the status's JSON.
#include <tellus/cluster/Control.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

using namespace tellus::cluster;

namespace {

ControlError refused(std::string_view method, std::string_view path, std::string_view body) {
  const auto r = parseControl(method, path, body);
  EXPECT_FALSE(r.has_value()) << method << " " << path << " " << body;
  return r ? ControlError{} : r.error();
}

} // namespace

TEST(Control, Status) {
  EXPECT_TRUE(std::holds_alternative<StatusQuery>(*parseControl("GET", "/status", "")));
  EXPECT_EQ(refused("POST", "/status", "{}").status, 405);
  EXPECT_EQ(refused("GET", "/nothing", "").status, 404);
  EXPECT_EQ(refused("GET", "/camera", "").status, 405);
}

TEST(Control, CameraKeepsWhatIsNotGiven) {
  const auto r = parseControl("POST", "/camera", R"({"lat": 46.5, "altitude": 2e5})");
  ASSERT_TRUE(r.has_value());
  const auto& c = std::get<CameraCommand>(*r);
  const tellus::planet::CameraPose p = applyCamera(c, {45.0, 7.0, 3e5, 10.0, 20.0});
  EXPECT_EQ(p.latDeg, 46.5);
  EXPECT_EQ(p.lonDeg, 7.0);
  EXPECT_EQ(p.altitudeM, 2e5);
  EXPECT_EQ(p.headingDeg, 10.0);
  EXPECT_EQ(p.tiltDeg, 20.0);
}

TEST(Control, BadBodiesAreRefused) {
  EXPECT_EQ(refused("POST", "/camera", "{\"lat\": ").message, "the body is not JSON");
  EXPECT_EQ(refused("POST", "/camera", "[1]").message, "the body must be a JSON object");
  EXPECT_EQ(refused("POST", "/camera", R"({"lat": 1, "zoom": 2})").message,
            "unknown field \"zoom\"");
  EXPECT_EQ(refused("POST", "/camera", R"({"lat": 91})").status, 400);
  EXPECT_EQ(refused("POST", "/camera", R"({"lat": "north"})").message, "lat must be a number");
  EXPECT_EQ(refused("POST", "/camera", R"({})").status, 400);
  EXPECT_EQ(refused("POST", "/camera", R"({"tilt": -1})").status, 400);
  EXPECT_EQ(refused("POST", "/time", R"({})").status, 400);
  EXPECT_EQ(refused("POST", "/time", R"({"utc": 1})").message, "unknown field \"utc\"");
  EXPECT_EQ(refused("POST", "/path", R"({"action": "rewind"})").status, 400);
  EXPECT_EQ(refused("POST", "/path", R"({"action": "seek"})").message, "seek needs seconds");
  EXPECT_EQ(refused("POST", "/path", R"({"action": "pause", "file": "a.json"})").status, 400);
  EXPECT_EQ(refused("POST", "/path", R"({"action": "seek", "seconds": -1})").status, 400);
}

TEST(Control, TimeAndPath) {
  EXPECT_EQ(std::get<TimeCommand>(*parseControl("POST", "/time", R"({"unix": 1.7e9})")).unixS,
            1.7e9);
  const auto play = std::get<PathCommand>(
      *parseControl("POST", "/path", R"({"action": "play", "file": "p.json"})"));
  EXPECT_EQ(play.action, PathCommand::Action::Play);
  EXPECT_EQ(play.file, "p.json");
  EXPECT_EQ(std::get<PathCommand>(*parseControl("POST", "/path", R"({"action": "pause"})")).action,
            PathCommand::Action::Pause);
  const auto seek = std::get<PathCommand>(
      *parseControl("POST", "/path", R"({"action": "seek", "seconds": 2.5})"));
  EXPECT_EQ(seek.action, PathCommand::Action::Seek);
  EXPECT_EQ(seek.seconds, 2.5);
}

TEST(Control, LayerKeepsWhatIsNotGiven) {
  const auto r = parseControl("POST", "/layer", R"({"layer": "sst", "opacity": 0.25})");
  ASSERT_TRUE(r.has_value());
  const auto& c = std::get<LayerCommand>(*r);
  EXPECT_EQ(c.layer, "sst");
  EXPECT_EQ(c.opacity, 0.25);
  EXPECT_FALSE(c.visible);
  EXPECT_FALSE(c.time);
  const auto t = std::get<LayerCommand>(*parseControl(
      "POST", "/layer", R"({"layer": "sst", "visible": false, "time": "2024-03-01"})"));
  EXPECT_EQ(t.visible, false);
  EXPECT_EQ(t.time, "2024-03-01");
  EXPECT_EQ(refused("POST", "/layer", R"({"opacity": 1})").message,
            "layer (a drawn layer's name) is required");
  EXPECT_EQ(refused("POST", "/layer", R"({"layer": "sst"})").message,
            "no field: opacity, visible, time");
  EXPECT_EQ(refused("POST", "/layer", R"({"layer": "sst", "opacity": 1.5})").status, 400);
  EXPECT_EQ(refused("POST", "/layer", R"({"layer": "sst", "visible": 1})").message,
            "visible must be true or false");
  EXPECT_EQ(refused("POST", "/layer", R"({"layer": "sst", "time": ""})").status, 400);
  EXPECT_EQ(refused("POST", "/layer", R"({"layer": "sst", "colour": "red"})").message,
            "unknown field \"colour\"");
  EXPECT_EQ(refused("GET", "/layer", "").status, 405);
}

TEST(Control, StatusJson) {
  StatusReport s;
  s.frame = 12;
  s.camera = {45.0, 7.0, 3e5, 0.0, 0.0};
  s.channels = {{"north", "alive", 12}, {"east", "lost", 4}};
  s.layers = {{"bluemarble", 1.0, true, ""}, {"sst", 0.5, false, "2024-03-01"}};
  const auto j = nlohmann::json::parse(statusJson(s));
  EXPECT_EQ(j["frame"], 12);
  EXPECT_EQ(j["camera"]["altitude"], 3e5);
  EXPECT_TRUE(j["time"].is_null());
  EXPECT_EQ(j["channels"][1]["name"], "east");
  EXPECT_EQ(j["channels"][1]["state"], "lost");
  EXPECT_EQ(j["channels"][1]["last_frame"], 4);
  EXPECT_EQ(j["layers"][1]["name"], "sst");
  EXPECT_EQ(j["layers"][1]["opacity"], 0.5);
  EXPECT_EQ(j["layers"][1]["visible"], false);
  EXPECT_EQ(j["layers"][1]["time"], "2024-03-01");
  EXPECT_EQ(nlohmann::json::parse(errorJson("no"))["error"], "no");
}
