// The dome's projector channels (issue 28): dome directions, a channel's frame and pinhole map,
// and the configuration's parser with its refusals.
#include <tellus/planet/Channels.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

using namespace tellus::planet;

namespace {

/** Four channels around at 20 degrees of elevation and one at the zenith, overlapping: the
 * configuration docs/design/cluster.md shows and the cluster's test renders. */
const char* kFiveChannels = R"({"channels": [
  {"name": "north", "azimuth": 0, "elevation": 20, "hfov": 110, "vfov": 90, "width": 200, "height": 140},
  {"name": "east", "azimuth": 90, "elevation": 20, "hfov": 110, "vfov": 90, "width": 200, "height": 140},
  {"name": "south", "azimuth": 180, "elevation": 20, "hfov": 110, "vfov": 90, "width": 200, "height": 140},
  {"name": "west", "azimuth": 270, "elevation": 20, "hfov": 110, "vfov": 90, "width": 200, "height": 140},
  {"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100, "roll": 0, "width": 140, "height": 140}
]})";

void expectNear(const glm::dvec3& a, const glm::dvec3& b, double tolerance = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

Channel channel(double az, double el, double h, double v, double roll, int width, int height) {
  Channel c;
  c.name = "c";
  c.azimuthDeg = az;
  c.elevationDeg = el;
  c.hfovDeg = h;
  c.vfovDeg = v;
  c.rollDeg = roll;
  c.width = width;
  c.height = height;
  return c;
}

std::string errorOf(const std::string& json) {
  const auto parsed = parseChannels(json, "dome.json");
  EXPECT_FALSE(parsed.has_value()) << json;
  return parsed ? std::string() : parsed.error();
}

} // namespace

TEST(Channels, DomeDirections) {
  expectNear(domeDirection(0, 90), {0, 0, -1});
  expectNear(domeDirection(0, 0), {0, 1, 0});
  expectNear(domeDirection(90, 0), {1, 0, 0});
  expectNear(domeDirection(180, 45), {0, -std::sqrt(0.5), -std::sqrt(0.5)});
}

TEST(Channels, FramesAreOrthonormalAndRightHanded) {
  for (const double az : {0.0, 37.0, 90.0, 200.0})
    for (const double el : {-30.0, 0.0, 20.0, 89.0, 90.0})
      for (const double roll : {0.0, 15.0, -90.0}) {
        const ChannelFrame f = channelFrame(channel(az, el, 90, 90, roll, 100, 100));
        expectNear(f.forward, domeDirection(az, el));
        EXPECT_NEAR(glm::length(f.up), 1.0, 1e-12);
        EXPECT_NEAR(glm::dot(f.forward, f.up), 0.0, 1e-12);
        expectNear(f.right, glm::cross(f.forward, f.up));
      }
  // Roll 0: up is where the elevation rises (the zenith side); at the zenith, away from the
  // azimuth. Roll 90 turns up onto the former right.
  expectNear(channelFrame(channel(0, 0, 90, 90, 0, 100, 100)).up, {0, 0, -1});
  expectNear(channelFrame(channel(0, 90, 90, 90, 0, 100, 100)).up, {0, -1, 0});
  const ChannelFrame still = channelFrame(channel(30, 10, 90, 90, 0, 100, 100));
  expectNear(channelFrame(channel(30, 10, 90, 90, 90, 100, 100)).up, still.right);
}

TEST(Channels, PinholeMapAndItsInverse) {
  const Channel c = channel(45, 20, 110, 90, 10, 200, 140);
  glm::dvec2 px;
  ASSERT_TRUE(projectToChannel(c, domeDirection(45, 20), px));
  EXPECT_NEAR(px.x, 100.0, 1e-9);
  EXPECT_NEAR(px.y, 70.0, 1e-9);
  // The right edge's midpoint lies hfov / 2 from the centre, the top edge's vfov / 2.
  const ChannelFrame f = channelFrame(c);
  const double h = 55.0 * std::numbers::pi / 180.0, v = 45.0 * std::numbers::pi / 180.0;
  ASSERT_TRUE(projectToChannel(c, std::cos(h) * f.forward + std::sin(h) * f.right, px));
  EXPECT_NEAR(px.x, 200.0, 1e-9);
  EXPECT_NEAR(px.y, 70.0, 1e-9);
  ASSERT_TRUE(projectToChannel(c, std::cos(v) * f.forward + std::sin(v) * f.up, px));
  EXPECT_NEAR(px.x, 100.0, 1e-9);
  EXPECT_NEAR(px.y, 0.0, 1e-9);
  EXPECT_FALSE(projectToChannel(c, -f.forward, px));
  for (const glm::dvec2 p : {glm::dvec2{0.5, 0.5}, glm::dvec2{199.5, 3.25}, glm::dvec2{61, 139}}) {
    ASSERT_TRUE(projectToChannel(c, channelPixelDirection(c, p), px));
    EXPECT_NEAR(px.x, p.x, 1e-9);
    EXPECT_NEAR(px.y, p.y, 1e-9);
  }
}

TEST(Channels, FiveChannelDomeCoversTheHemisphere) {
  const auto channels = parseChannels(kFiveChannels);
  ASSERT_TRUE(channels.has_value()) << channels.error();
  ASSERT_EQ(channels->size(), 5u);
  int overlapped = 0, samples = 0;
  for (double el = 0.0; el <= 90.0; el += 2.5)
    for (double az = 0.0; az < 360.0; az += 2.5) {
      int seen = 0;
      for (const Channel& c : *channels) {
        glm::dvec2 px;
        if (projectToChannel(c, domeDirection(az, el), px) && px.x >= 0 && px.x <= c.width &&
            px.y >= 0 && px.y <= c.height)
          ++seen;
      }
      EXPECT_GE(seen, 1) << "azimuth " << az << ", elevation " << el << " seen by no channel";
      overlapped += seen > 1;
      ++samples;
    }
  EXPECT_GT(overlapped, samples / 10); // the channels overlap, as projectors blending do
}

TEST(Channels, RefusesMalformedConfigurations) {
  const std::string channel = R"("name": "a", "azimuth": 0, "elevation": 20, "hfov": 90,)"
                              R"( "vfov": 90, "width": 100)";
  EXPECT_EQ(errorOf("{"), "dome.json: not JSON");
  EXPECT_EQ(errorOf("[]"), "dome.json: not a JSON object");
  EXPECT_EQ(errorOf(R"({"channel": []})"), "dome.json: unknown key \"channel\"");
  EXPECT_EQ(errorOf(R"({"channels": []})"), "dome.json: channels: not a non-empty array");
  EXPECT_EQ(errorOf("{\"channels\": [{" + channel + "}]}"),
            "dome.json: channels[0]: height: missing");
  EXPECT_EQ(errorOf("{\"channels\": [{" + channel + R"(, "height": 100, "mpcdi": "w.pfm"}]})"),
            "dome.json: channels[0]: unknown key \"mpcdi\"");
  EXPECT_EQ(errorOf("{\"channels\": [{" + channel + R"(, "height": 100, "warp": 3}]})"),
            "dome.json: channels[0]: warp: a file name is required");
  const std::string ok = "{" + channel + R"(, "height": 100})";
  EXPECT_EQ(errorOf("{\"channels\": [" + ok + ", " + ok + "]}"),
            "dome.json: channels[1]: name \"a\" repeated");
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a b"}]})").find("channels[0]: name: must be"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20, "hfov": 180,)"
                    R"( "vfov": 90, "width": 100, "height": 100}]})")
                .find("channels[0]: hfov: 180"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a", "azimuth": "n", "elevation": 20}]})")
                .find("channels[0]: azimuth: not a number"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20, "hfov": 90,)"
                    R"( "vfov": 60, "width": 100, "height": 100}]})")
                .find("channels[0]: pixels not square"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20, "hfov": 90,)"
                    R"( "vfov": 90, "width": 0, "height": 100}]})")
                .find("channels[0]: width: 0 not in [1, 16384]"),
            std::string::npos);
}

TEST(Channels, ARenderSizeOtherThanTheProjectorsIsTheFrustumsPixels) {
  // A 200 x 140 projector fed by a 400 x 280 image: the frustum's pixels are the rendered ones.
  const auto parsed = parseChannels(
      R"({"channels": [{"name": "a", "azimuth": 45, "elevation": 20, "hfov": 110, "vfov": 90,)"
      R"( "roll": 10, "width": 200, "height": 140, "render": [400, 280]}]})");
  ASSERT_TRUE(parsed.has_value()) << parsed.error();
  const Channel& c = parsed->front();
  EXPECT_EQ(c.width, 200);
  EXPECT_EQ(c.renderedWidth(), 400);
  EXPECT_EQ(c.renderedHeight(), 280);
  glm::dvec2 px;
  ASSERT_TRUE(projectToChannel(c, domeDirection(45, 20), px));
  EXPECT_NEAR(px.x, 200.0, 1e-9); // the centre of 400 x 280
  EXPECT_NEAR(px.y, 140.0, 1e-9);
  const Channel same = channel(45, 20, 110, 90, 10, 200, 140);
  for (const glm::dvec2 p : {glm::dvec2{0.5, 0.5}, glm::dvec2{199.5, 3.25}, glm::dvec2{61, 139}}) {
    // The same direction at twice the pixel coordinates.
    expectNear(channelPixelDirection(c, 2.0 * p), channelPixelDirection(same, p), 1e-12);
  }
  EXPECT_EQ(same.renderedWidth(), 200); // no render size: the projector's
  const std::string head = R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20,)"
                           R"( "hfov": 90, "vfov": 90, "width": 100, "height": 100, )";
  // Square pixels are asked of the rendered image; without a warp the aspects must agree.
  EXPECT_NE(errorOf(head + R"("render": [200, 150]}]})").find("pixels not square: render is"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20, "hfov": 90,)"
                    R"( "vfov": 90, "width": 160, "height": 100, "render": [200, 200]}]})")
                .find("without a warp the projector shows the rendered image scaled"),
            std::string::npos);
  // With a warp the projector's pixels are the warp's business.
  EXPECT_TRUE(parseChannels(R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20,)"
                            R"( "hfov": 90, "vfov": 90, "width": 160, "height": 100,)"
                            R"( "render": [200, 200], "warp": "w.json"}]})")
                  .has_value());
  EXPECT_EQ(errorOf(head + R"("render": 2}]})"),
            "dome.json: channels[0]: render: [width, height] of the rendered image is required");
  EXPECT_EQ(errorOf(head + R"("render": [0, 100]}]})"),
            "dome.json: channels[0]: render: width: 0 not in [1, 16384]");
  EXPECT_EQ(errorOf(head + R"("render": [100, 1.5]}]})"),
            "dome.json: channels[0]: render: height: not an integer");
}

TEST(Channels, ReadsAFileAndNamesItInErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "tellus-channels-test";
  std::filesystem::create_directories(dir);
  const auto file = dir / "dome.json";
  std::ofstream(file) << kFiveChannels;
  const auto read = readChannels(file);
  ASSERT_TRUE(read.has_value()) << read.error();
  EXPECT_EQ(read->back().name, "zenith");
  EXPECT_TRUE(read->back().warp.empty());
  std::ofstream(file) << R"({"channels": [{"name": "a", "azimuth": 0, "elevation": 20, "hfov": 90,
    "vfov": 90, "width": 10, "height": 10, "warp": "w.json", "blend": "/m/b.png"}]})";
  const auto withFiles = readChannels(file);
  ASSERT_TRUE(withFiles.has_value()) << withFiles.error();
  EXPECT_EQ(withFiles->front().warp, dir / "w.json"); // beside the configuration
  EXPECT_EQ(withFiles->front().blend, std::filesystem::path("/m/b.png"));
  const auto missing = readChannels(dir / "none.json");
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error(), (dir / "none.json").string() + ": cannot be read");
  std::filesystem::remove_all(dir);
}
