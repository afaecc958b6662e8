#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

using namespace tellus;
namespace fs = std::filesystem;

namespace {
const fs::path kData = TELLUS_TEST_DATA_DIR;
const fs::path kExamples = kData.parent_path() / "config" / "examples";

/** Sets an environment variable for the scope and puts the old value back. */
class ScopedEnv {
public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      ::setenv(name, value, 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

private:
  const char* name_;
  std::optional<std::string> old_;
};
} // namespace

TEST(Config, EmbeddedDefaultIsValidAndServesTheBundledData) {
  const Config c = embeddedDefault(kData, "/tmp/cache");
  ASSERT_TRUE(validate(c)) << validate(c).error();
  ASSERT_NE(c.layer("bluemarble"), nullptr);
  ASSERT_NE(c.layer("etopo"), nullptr);
  EXPECT_EQ(c.layer("nope"), nullptr);
  EXPECT_EQ(c.layer("bluemarble")->dataset.grid.levelZeroDeltaDeg, 36.0);
  EXPECT_EQ(c.layer("bluemarble")->dataset.grid.tileWidth, 512);
  EXPECT_EQ(c.layer("bluemarble")->dataset.grid.numLevels, 3);
  EXPECT_EQ(c.layer("bluemarble")->dataset.mimeType, "image/jpeg");
  EXPECT_EQ(c.layer("bluemarble")->dataset.extension, "jpg");
  EXPECT_EQ(c.layer("bluemarble")->dataset.server, "local");
  EXPECT_EQ(c.layer("bluemarble")->kind, LayerKind::Imagery);
  EXPECT_EQ(c.layer("etopo")->dataset.grid.levelZeroDeltaDeg, 20.0);
  EXPECT_EQ(c.layer("etopo")->dataset.grid.tileWidth, 150);
  EXPECT_EQ(c.layer("etopo")->dataset.grid.tileHeight, 150);
  EXPECT_EQ(c.layer("etopo")->dataset.mimeType, "application/bil16");
  EXPECT_EQ(c.layer("etopo")->dataset.extension, "bil");
  EXPECT_EQ(c.layer("etopo")->kind, LayerKind::Elevation);
  EXPECT_TRUE(c.layer("bluemarble")->dataset.pinned);
  EXPECT_TRUE(c.layer("etopo")->dataset.pinned);
  EXPECT_EQ(c.cache.root, "/tmp/cache");

  const UpstreamConfig* bmng = c.upstream(c.layer("bluemarble")->upstream);
  ASSERT_NE(bmng, nullptr);
  EXPECT_EQ(bmng->type, UpstreamConfig::Type::Local);
  EXPECT_EQ(bmng->path, (kData / "bmng_2048x1024.jpg").lexically_normal());
  const UpstreamConfig* etopo = c.upstream(c.layer("etopo")->upstream);
  ASSERT_NE(etopo, nullptr);
  EXPECT_EQ(etopo->path, (kData / "etopo20_int16.tif").lexically_normal());
  EXPECT_EQ(c.upstream("nope"), nullptr);
}

TEST(Config, EmbeddedDefaultIsDefaultYamlCompiledIn) {
  std::ifstream in(kExamples / "default.yaml", std::ios::binary);
  ASSERT_TRUE(in);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(embeddedDefaultYaml(), text.str());

  // The same file loaded from disk resolves data_dir (../../data) to the bundled data.
  const auto loaded = loadConfig(kExamples / "default.yaml");
  ASSERT_TRUE(loaded) << loaded.error().toString();
  const Config embedded = embeddedDefault(kData, "/tmp/cache");
  ASSERT_EQ(loaded->layers.size(), embedded.layers.size());
  for (std::size_t i = 0; i < embedded.layers.size(); ++i) {
    EXPECT_EQ(datasetFolder(loaded->layers[i].dataset), datasetFolder(embedded.layers[i].dataset));
    EXPECT_EQ(loaded->upstream(loaded->layers[i].upstream)->path,
              embedded.upstream(embedded.layers[i].upstream)->path);
  }
}

TEST(Config, EmbeddedDefaultWithoutCacheRootUsesTheDefaultRoot) {
  const ScopedEnv env("TELLUS_CACHE", "/srv/tellus-cache");
  EXPECT_EQ(embeddedDefault(kData, {}).cache.root, "/srv/tellus-cache");
}

TEST(Config, ValidationNamesTheLayerAndTheField) {
  Config c = embeddedDefault(kData, "/tmp/cache");
  Config dup = c;
  dup.layers.push_back(dup.layers[0]);
  ASSERT_FALSE(validate(dup));
  EXPECT_NE(validate(dup).error().find("'bluemarble'"), std::string::npos);
  Config grid = c;
  grid.layers[1].dataset.grid.levelZeroDeltaDeg = 7.0;
  ASSERT_FALSE(validate(grid));
  EXPECT_NE(validate(grid).error().find("'etopo'"), std::string::npos);
  Config fmt = c;
  fmt.layers[0].dataset.mimeType = "image/bmp";
  ASSERT_FALSE(validate(fmt));
  EXPECT_NE(validate(fmt).error().find("format"), std::string::npos);
  Config missing = embeddedDefault("/nonexistent", "/tmp/cache");
  ASSERT_FALSE(validate(missing));
  EXPECT_NE(validate(missing).error().find("does not exist"), std::string::npos);
  Config unnamed = c;
  unnamed.layers[0].name.clear();
  EXPECT_FALSE(validate(unnamed));
  Config noUpstream = c;
  noUpstream.layers[0].upstream = "elsewhere";
  ASSERT_FALSE(validate(noUpstream));
  EXPECT_NE(validate(noUpstream).error().find("no upstream named 'elsewhere'"), std::string::npos);
  Config dupUpstream = c;
  dupUpstream.upstreams.push_back(dupUpstream.upstreams[0]);
  ASSERT_FALSE(validate(dupUpstream));
  EXPECT_NE(validate(dupUpstream).error().find("used twice"), std::string::npos);
  Config badUrl = c;
  badUrl.upstreams[0].type = UpstreamConfig::Type::Wms;
  badUrl.upstreams[0].url = "ftp://example.org/wms";
  ASSERT_FALSE(validate(badUrl));
  EXPECT_NE(validate(badUrl).error().find("http"), std::string::npos);
  Config badTimeout = c;
  badTimeout.upstreams[0].type = UpstreamConfig::Type::Wms;
  badTimeout.upstreams[0].url = "http://example.org/wms";
  badTimeout.upstreams[0].timeout = std::chrono::milliseconds(0);
  ASSERT_FALSE(validate(badTimeout));
  EXPECT_NE(validate(badTimeout).error().find("timeout"), std::string::npos);
}

TEST(Config, RendererSettingsAreValidated) {
  const Config c = embeddedDefault(kData, "/tmp/cache");
  EXPECT_TRUE(validate(c));
  EXPECT_EQ(c.renderer.meshSize, 33);
  const auto fails = [&](auto change, const char* key) {
    Config bad = c;
    change(bad.renderer);
    const auto v = validate(bad);
    ASSERT_FALSE(v) << key;
    EXPECT_NE(v.error().find(std::string("renderer: ") + key), std::string::npos) << v.error();
  };
  fails([](RendererSettings& g) { g.lodThreshold = 0.0; }, "lod_threshold");
  fails([](RendererSettings& g) { g.lodThreshold = std::nan(""); }, "lod_threshold");
  fails([](RendererSettings& g) { g.lodThreshold = INFINITY; }, "lod_threshold");
  fails([](RendererSettings& g) { g.meshSize = 32; }, "mesh_size");
  fails([](RendererSettings& g) { g.meshSize = 513; }, "mesh_size");
  fails([](RendererSettings& g) { g.fovDeg = 180.0; }, "fov");
  { // renderer.overview (issue 29): an imagery layer of the configuration
    Config bad = c;
    bad.renderer.overview = "no-such-layer";
    const auto v = validate(bad);
    ASSERT_FALSE(v);
    EXPECT_NE(v.error().find("overview"), std::string::npos) << v.error();
    bad.renderer.overview = c.renderer.layers.at(0).layer;
    EXPECT_TRUE(validate(bad));
  }
  fails([](RendererSettings& g) { g.textureBudget = 1000; }, "texture_budget");
  fails([](RendererSettings& g) { g.uploadPerFrame = 0; }, "upload_per_frame");
  fails([](RendererSettings& g) { g.maxInFlight = 0; }, "max_in_flight");
  fails([](RendererSettings& g) { g.maxSplitsPerFrame = 0; }, "max_splits_per_frame");
  fails([](RendererSettings& g) { g.decodeThreads = 0; }, "decode_threads");
  fails([](RendererSettings& g) { g.earth = static_cast<EarthShape>(7); }, "earth");
  fails([](RendererSettings& g) { g.time = "yesterday"; }, "time");
  fails([](RendererSettings& g) { g.time = "2024-02-30"; }, "time");
  fails([](RendererSettings& g) { g.overlaysPerPass = 9; }, "overlays_per_pass");
  fails([](RendererSettings& g) { g.overlaysPerPass = -1; }, "overlays_per_pass");
  fails([](RendererSettings& g) { g.fadeInS = -0.1; }, "fade_in");
  fails([](RendererSettings& g) { g.fadeInS = 11.0; }, "fade_in");
  fails([](RendererSettings& g) { g.fadeInS = std::nan(""); }, "fade_in");
  fails([](RendererSettings& g) { g.dome.directMaxErrorPx = -1.0; }, "dome.direct_max_error");
  fails([](RendererSettings& g) { g.dome.directMaxErrorPx = std::nan(""); },
        "dome.direct_max_error");
  fails([](RendererSettings& g) { g.dome.fovDeg = 221.0; }, "dome.fov");
  fails([](RendererSettings& g) { g.atmosphere.exposure = 0.0; }, "atmosphere.exposure");
  fails([](RendererSettings& g) { g.atmosphere.mieG = 1.0; }, "atmosphere.mie_g");
  fails([](RendererSettings& g) { g.atmosphere.topAltitude = std::nan(""); },
        "atmosphere.top_altitude");
  fails([](RendererSettings& g) { g.atmosphere.mieExtinction = 1e-6; },
        "atmosphere.mie_extinction");
  fails([](RendererSettings& g) { g.atmosphere.groundAlbedo[1] = 2.0; },
        "atmosphere.ground_albedo");
  fails([](RendererSettings& g) { g.dome.fovDeg = 0.0; }, "dome.fov");
  fails([](RendererSettings& g) { g.dome.tiltDeg = std::nan(""); }, "dome.tilt");
  fails([](RendererSettings& g) { g.dome.faceScale = 0.05; }, "dome.face_scale");
  fails([](RendererSettings& g) { g.stars.magnitudeLimit = std::nan(""); },
        "stars.magnitude_limit");
  fails([](RendererSettings& g) { g.stars.magnitudeLimit = 30.0; }, "stars.magnitude_limit");
  fails([](RendererSettings& g) { g.stars.brightness = -0.1; }, "stars.brightness");
  fails([](RendererSettings& g) { g.stars.brightness = INFINITY; }, "stars.brightness");
  fails([](RendererSettings& g) { g.terrain.minReliefPx = -1.0; }, "terrain.min_relief_px");
  fails([](RendererSettings& g) { g.terrain.minReliefPx = std::nan(""); }, "terrain.min_relief_px");
  EXPECT_EQ(c.renderer.earth, EarthShape::Wgs84);
  EXPECT_TRUE(c.renderer.geoid);
  Config ok = c;
  ok.renderer.earth = EarthShape::Sphere;
  ok.renderer.geoid = false;
  EXPECT_TRUE(validate(ok));
  ok.renderer.meshSize = 3;
  ok.renderer.lodThreshold = 64.0;
  EXPECT_TRUE(validate(ok));
}

TEST(Config, DefaultCacheRootFollowsTheEnvironment) {
  const ScopedEnv cache("TELLUS_CACHE", "/srv/tellus");
  const ScopedEnv xdg("XDG_CACHE_HOME", nullptr);
  const ScopedEnv home("HOME", "/home/u");
  EXPECT_EQ(defaultCacheRoot(), "/srv/tellus");
  ::unsetenv("TELLUS_CACHE");
  ::setenv("XDG_CACHE_HOME", "/x", 1);
  EXPECT_EQ(defaultCacheRoot(), "/x/tellus");
  ::unsetenv("XDG_CACHE_HOME");
  EXPECT_EQ(defaultCacheRoot(), "/home/u/.cache/tellus");
}

TEST(Config, DurationsAndSizes) {
  using std::chrono::milliseconds;
  EXPECT_EQ(parseDurationText("500ms"), milliseconds(500));
  EXPECT_EQ(parseDurationText("30s"), milliseconds(30'000));
  EXPECT_EQ(parseDurationText("5m"), milliseconds(300'000));
  EXPECT_EQ(parseDurationText("12h"), milliseconds(43'200'000));
  EXPECT_EQ(parseDurationText("30d"), milliseconds(2'592'000'000));
  EXPECT_EQ(parseDurationText("0"), milliseconds(0));
  EXPECT_EQ(parseDurationText("0s"), milliseconds(0));
  EXPECT_FALSE(parseDurationText("30"));
  EXPECT_FALSE(parseDurationText("10 parsecs"));
  EXPECT_FALSE(parseDurationText("-5s"));
  EXPECT_FALSE(parseDurationText("1.5s"));
  EXPECT_FALSE(parseDurationText(""));
  EXPECT_FALSE(parseDurationText("s"));

  EXPECT_EQ(parseSizeText("1000000"), 1'000'000U);
  EXPECT_EQ(parseSizeText("512MiB"), 512ULL << 20);
  EXPECT_EQ(parseSizeText("10GiB"), 10ULL << 30);
  EXPECT_EQ(parseSizeText("2 GB"), 2'000'000'000ULL);
  EXPECT_EQ(parseSizeText("1TiB"), 1ULL << 40);
  EXPECT_EQ(parseSizeText("0"), 0U);
  EXPECT_FALSE(parseSizeText("lots"));
  EXPECT_FALSE(parseSizeText("10 GiBs"));
  EXPECT_FALSE(parseSizeText("-1"));
  EXPECT_FALSE(parseSizeText("1.5GiB"));
}

TEST(Config, ErrorTextNamesFileLineColumnAndKey) {
  ConfigError e{"a.yaml", 3, 7, "layers[1].grid.levels", "must be in [1, 31]"};
  EXPECT_EQ(e.toString(), "a.yaml:3:7: layers[1].grid.levels: must be in [1, 31]");
  e.column = 0;
  EXPECT_EQ(e.toString(), "a.yaml:3: layers[1].grid.levels: must be in [1, 31]");
  e.line = 0;
  e.key.clear();
  EXPECT_EQ(e.toString(), "a.yaml: must be in [1, 31]");
}

TEST(Config, EmbeddedDefaultLightsTheDaySideAndShowsTheNightLights) {
  const Config c = embeddedDefault(kData, "/tmp/cache");
  ASSERT_TRUE(validate(c));
  EXPECT_TRUE(c.renderer.sunlight);
  EXPECT_TRUE(c.renderer.night);
  EXPECT_EQ(c.renderer.time, "") << "the command's default: render's fixed time, view's now";
  ASSERT_EQ(c.renderer.layers.size(), 2u);
  EXPECT_EQ(c.renderer.layers[0].layer, "bluemarble");
  EXPECT_FALSE(c.renderer.layers[0].night);
  EXPECT_EQ(c.renderer.layers[1].layer, "nightlights");
  EXPECT_TRUE(c.renderer.layers[1].night);
  Config base = c;
  base.renderer.layers[0].night = true;
  ASSERT_FALSE(validate(base)) << "the opaque base cannot be a night layer";
  EXPECT_NE(validate(base).error().find("night"), std::string::npos);
  Config timed = c;
  // Every form `--time` takes (one ISO 8601 reader, cache/IsoTime.hpp): a fraction, an offset.
  for (const char* t : {"now",
                        "2024-06-20",
                        "2024-06-20T12:00:00Z",
                        "1900-01-01T00:00",
                        "2024-06-20T12:00:00.5Z",
                        "2024-06-20T14:00+02:00"}) {
    timed.renderer.time = t;
    EXPECT_TRUE(validate(timed)) << t;
  }
}
