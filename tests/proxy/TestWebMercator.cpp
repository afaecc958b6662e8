// Web Mercator (EPSG:3857) maps: the projection's formulas at their extremes, the bands a map is
// composed in, maps composed from synthetic lat/long tiles whose samples are their own latitude
// (so each row says which latitude it was sampled at: checked against the inverse Mercator, row by
// row), nothing past the Mercator square, and the WMS parameters (aliases, axis order, InvalidCRS)
// and capabilities.

#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/MapBox.hpp>
#include <tellus/proxy/Wms.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <tuple>

using namespace tellus;
using namespace tellus::mercator;

namespace {

TileGrid grid(std::int32_t tile, std::int32_t levels) {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, tile, tile, levels});
}

/** The latitude of texel row `gy` (from the north) at `level`: its centre. */
double texelLatitude(const TileGrid& g, std::int32_t level, std::int64_t gy) {
  return 90.0 - (static_cast<double>(gy) + 0.5) * g.deltaDeg(level) / g.spec().tileHeight;
}

/** Tiles (made when first asked for) whose samples are their texel's latitude: values (float),
 * imagery whose green is 255 * (90 - latitude) / 180 rounded and blue 10 * level, or that green
 * alone as one plane. */
struct LatitudeTiles {
  enum class Kind { Values, Rgb, Green };
  const TileGrid& g;
  Kind kind;
  mutable std::map<std::tuple<int, std::int64_t, std::int64_t>, std::unique_ptr<TileSamples>> tiles;
  mutable std::vector<std::unique_ptr<std::vector<float>>> values;
  mutable std::vector<std::unique_ptr<std::vector<std::uint8_t>>> rgb;

  LatitudeTiles(const TileGrid& grid, Kind k) : g(grid), kind(k) {}

  const TileSamples* make(const TileKey& k) const {
    const auto w = g.spec().tileWidth, h = g.spec().tileHeight;
    auto s = std::make_unique<TileSamples>();
    s->width = w;
    s->height = h;
    const std::int64_t gy0 = (g.rowCount(k.level) - 1 - k.row) * h;
    const auto n = static_cast<std::size_t>(w * h);
    const auto green = [&](int y) {
      return static_cast<std::uint8_t>(
          std::lround(255.0 * (90.0 - texelLatitude(g, k.level, gy0 + y)) / 180.0));
    };
    if (kind == Kind::Values) {
      auto v = std::make_unique<std::vector<float>>(n);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          (*v)[static_cast<std::size_t>(y * w + x)] =
              static_cast<float>(texelLatitude(g, k.level, gy0 + y));
      s->channels = 1;
      s->values = v->data();
      values.push_back(std::move(v));
    } else {
      const std::size_t cc = kind == Kind::Rgb ? 3 : 1;
      auto v = std::make_unique<std::vector<std::uint8_t>>(n * cc);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          auto* p = &(*v)[static_cast<std::size_t>(y * w + x) * cc];
          if (cc == 1) {
            p[0] = green(y);
            continue;
          }
          p[0] = 7;
          p[1] = green(y);
          p[2] = static_cast<std::uint8_t>(10 * k.level);
        }
      s->channels = static_cast<std::int32_t>(cc);
      s->rgb = v->data();
      rgb.push_back(std::move(v));
    }
    return (tiles[{k.level, k.row, k.col}] = std::move(s)).get();
  }
  TileLookup lookup() const {
    return [this](const TileKey& k) -> const TileSamples* {
      if (!g.isValid(k)) return nullptr;
      const auto it = tiles.find({k.level, k.row, k.col});
      return it == tiles.end() ? make(k) : it->second.get();
    };
  }
};

/** The y of row j's centre in a map of `height` rows from northY to southY. */
double rowY(const MapBox& b, std::int32_t j, std::int32_t height) {
  return b.northY - (j + 0.5) * ((b.northY - b.southY) / height);
}

std::vector<float> composeAllBands(const TileGrid& g,
                                   const MapBox& box,
                                   std::int32_t width,
                                   std::int32_t height,
                                   const TileLookup& lookup) {
  std::vector<float> values(static_cast<std::size_t>(width * height),
                            std::numeric_limits<float>::quiet_NaN());
  for (const ComposeBand& b : composeBands(g, box, width, height, 0)) {
    const auto stats = composeValues(g, b.box, width, height, b.level, 0, lookup, values);
    EXPECT_EQ(stats.missingPixels, 0u);
  }
  return values;
}

} // namespace

TEST(WebMercator, ProjectionAtTheExtremes) {
  EXPECT_EQ(yOfLatitude(0.0), 0.0);
  EXPECT_EQ(latitudeOfY(0.0), 0.0);
  EXPECT_NEAR(kMaxY, 20037508.342789244, 1e-8);
  // The square's edge is atan(sinh(pi)): y(kMaxLatitude) = pi R, and back.
  EXPECT_NEAR(
      kMaxLatitude, std::atan(std::sinh(std::numbers::pi)) * 180.0 / std::numbers::pi, 1e-12);
  EXPECT_NEAR(yOfLatitude(kMaxLatitude), kMaxY, 1e-6);
  EXPECT_NEAR(yOfLatitude(-kMaxLatitude), -kMaxY, 1e-6);
  EXPECT_NEAR(latitudeOfY(kMaxY), kMaxLatitude, 1e-12);
  EXPECT_NEAR(latitudeOfY(-kMaxY), -kMaxLatitude, 1e-12);
  // Known values (EPSG's own formula): 45 N and 80 N.
  EXPECT_NEAR(yOfLatitude(45.0), 5621521.486192066, 1e-6);
  EXPECT_NEAR(yOfLatitude(80.0), 15538711.096309224, 1e-6);
  // The antimeridian: x = +-pi R.
  EXPECT_NEAR(xOfLongitude(180.0), kMaxY, 1e-8);
  EXPECT_NEAR(xOfLongitude(-180.0), -kMaxY, 1e-8);
  EXPECT_NEAR(longitudeOfX(kMaxY), 180.0, 1e-12);
  EXPECT_NEAR(longitudeOfX(-kMaxY), -180.0, 1e-12);
  // Round trips over the square: under a micrometre and 1e-12 degrees.
  double worstY = 0.0, worstLat = 0.0;
  for (double lat = -kMaxLatitude; lat <= kMaxLatitude; lat += 0.0137) {
    worstLat = std::max(worstLat, std::fabs(latitudeOfY(yOfLatitude(lat)) - lat));
    const double y = yOfLatitude(lat);
    worstY = std::max(worstY, std::fabs(yOfLatitude(latitudeOfY(y)) - y));
  }
  EXPECT_LT(worstLat, 1e-12);
  EXPECT_LT(worstY, 1e-6);
  // Past the square the inverse still answers, below 90.
  EXPECT_GT(latitudeOfY(2.0 * kMaxY), kMaxLatitude);
  EXPECT_LE(latitudeOfY(1e12), 90.0);
}

TEST(WebMercator, RowsAreTheInverseMercatorOfTheirCentres) {
  const MapBox b = mercatorBox(Sector{-kMaxY, -kMaxY, kMaxY, kMaxY});
  EXPECT_EQ(b.rows, MapRows::Mercator);
  EXPECT_NEAR(b.west, -180.0, 1e-12);
  EXPECT_NEAR(b.east, 180.0, 1e-12);
  EXPECT_NEAR(b.north, kMaxLatitude, 1e-12);
  EXPECT_NEAR(b.south, -kMaxLatitude, 1e-12);
  // The middle rows of an even map straddle the equator; the quarter row is at y = pi R / 2.
  EXPECT_NEAR(b.rowLatitude(127, 256), -b.rowLatitude(128, 256), 1e-12);
  EXPECT_NEAR(b.rowEdgeLatitude(64, 256), latitudeOfY(kMaxY / 2), 1e-12);
  EXPECT_NEAR(b.rowEdgeLatitude(64, 256), 66.51326044311186, 1e-9);
  // A box above the square: every row is past it.
  const MapBox above = mercatorBox(Sector{0, kMaxY, 1e6, kMaxY + 1e6});
  for (int j = 0; j < 8; ++j)
    EXPECT_TRUE(std::isnan(above.rowLatitude(j, 8)));
  // A plain Sector is a box of latitude rows.
  const MapBox plain = Sector{0, -10, 10, 10};
  EXPECT_EQ(plain.rows, MapRows::Latitude);
  EXPECT_DOUBLE_EQ(plain.rowLatitude(0, 20), 9.5);
}

// A world map in Web Mercator: finer levels toward the poles, bands in order, covering every row;
// a map of latitude rows is one band at composeLevel.
TEST(WebMercator, BandsTakeFinerLevelsTowardThePoles) {
  const auto g = grid(64, 8);
  const MapBox world = mercatorBox(Sector{-kMaxY, -kMaxY, kMaxY, kMaxY});
  const auto bands = composeBands(g, world, 512, 512, 0);
  ASSERT_GE(bands.size(), 5u);
  EXPECT_EQ(bands.front().box.rowBegin, 0);
  EXPECT_EQ(bands.back().box.rowEnd, 512);
  for (std::size_t k = 1; k < bands.size(); ++k)
    EXPECT_EQ(bands[k].box.rowBegin, bands[k - 1].box.rowEnd);
  // Symmetric about the equator; the equator at the longitude's need (0.703 deg pixels: level 0,
  // 0.5625 deg texels), each row at the coarsest level whose texels are at most kMaxUpsampling
  // times its pixel's extent in latitude.
  EXPECT_EQ(bands.front().level, bands.back().level);
  const auto levelOfRow = [&](std::int32_t j) {
    for (const auto& b : bands)
      if (b.box.drawsRow(j)) return b.level;
    return -1;
  };
  EXPECT_EQ(levelOfRow(255), 0);
  for (const std::int32_t j : {0, 10, 40, 100, 200}) {
    const double extent = world.rowEdgeLatitude(j, 512) - world.rowEdgeLatitude(j + 1, 512);
    const std::int32_t l = levelOfRow(j);
    EXPECT_LE(g.deltaDeg(l) / 64, kMaxUpsampling * extent * (1 + 1e-9)) << j;
    if (l > 0) {
      EXPECT_GT(g.deltaDeg(l - 1) / 64, kMaxUpsampling * extent) << j;
    }
  }
  EXPECT_EQ(composeLevel(g, world, 512, 512, 0), bands.front().level);
  const auto plain = composeBands(g, Sector{-180, -90, 180, 90}, 512, 256, 0);
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain.front().level, composeLevel(g, Sector{-180, -90, 180, 90}, 512, 256, 0));
}

// Every row's value is its latitude (the tiles' samples are their latitude; bilinear on a linear
// field is exact up to float rounding): the inverse Mercator of the row centre's y, from the
// equator to 85.05 N; the rows past the square have no value.
TEST(WebMercator, ValuesRowByRowAreTheInverseMercator) {
  const auto g = grid(32, 7);
  const LatitudeTiles tiles(g, LatitudeTiles::Kind::Values);
  // 10 W .. 10 E, from 1000 km south of the equator to 2000 km past the square's north edge.
  const Sector metres{-1113194.9, -1.0e6, 1113194.9, kMaxY + 2.0e6};
  const MapBox box = mercatorBox(metres);
  const std::int32_t w = 16, h = 300;
  const auto values = composeAllBands(g, box, w, h, tiles.lookup());
  std::int32_t past = 0;
  for (std::int32_t j = 0; j < h; ++j) {
    const double y = rowY(box, j, h);
    for (std::int32_t i = 0; i < w; i += 5) {
      const float v = values[static_cast<std::size_t>(j * w + i)];
      if (y > kMaxY) {
        EXPECT_TRUE(std::isnan(v)) << j;
      } else {
        EXPECT_NEAR(v, latitudeOfY(y), 2e-5) << "row " << j;
      }
    }
    if (y > kMaxY) ++past;
  }
  EXPECT_GT(past, 10);
  // Not what rows evenly in latitude would give (the stretching this replaces): 20 degrees off
  // in the middle of the map.
  const double linear = box.north - (h / 2 + 0.5) * (box.north - box.south) / h;
  EXPECT_GT(std::fabs(static_cast<double>(values[static_cast<std::size_t>(h / 2 * w)]) - linear),
            5.0);
}

// Around 80 N (a map of 200 km square, 64 x 64 pixels): rows at the inverse Mercator, and each row
// from a level whose texels are at most kMaxUpsampling times as tall as its pixels (magnified no
// more than any map), the same level for the imagery (blue = 10 * level).
TEST(WebMercator, At80DegreesRowsAreNeitherStretchedNorBlurred) {
  const auto g = grid(32, 10);
  const LatitudeTiles values(g, LatitudeTiles::Kind::Values);
  const LatitudeTiles picture(g, LatitudeTiles::Kind::Rgb);
  const double y80 = yOfLatitude(80.0);
  const MapBox box = mercatorBox(Sector{1.0e6, y80 - 1.0e5, 1.2e6, y80 + 1.0e5});
  const std::int32_t w = 64, h = 64;
  const auto v = composeAllBands(g, box, w, h, values.lookup());
  std::vector<std::uint8_t> canvas(static_cast<std::size_t>(w * h * 4), 0);
  for (const ComposeBand& b : composeBands(g, box, w, h, 0))
    composeImagery(g, b.box, w, h, b.level, 0, picture.lookup(), 1.0, canvas);
  for (std::int32_t j = 0; j < h; ++j) {
    const double lat = latitudeOfY(rowY(box, j, h));
    EXPECT_NEAR(v[static_cast<std::size_t>(j * w + 3)], lat, 2e-5) << j;
    const std::uint8_t* p = &canvas[static_cast<std::size_t>((j * w + 3) * 4)];
    EXPECT_NEAR(p[1], 255.0 * (90.0 - lat) / 180.0, 1.01) << j;
    const std::int32_t level = p[2] / 10;
    const double extent = box.rowEdgeLatitude(j, h) - box.rowEdgeLatitude(j + 1, h);
    EXPECT_LE(g.deltaDeg(level) / 32, kMaxUpsampling * extent * (1 + 1e-9)) << j;
    EXPECT_EQ(p[3], 255);
  }
  // The longitude's need alone (1.8 degrees over 64 px = 0.028 deg) would take level 5 here (a
  // 0.035 deg texel, 1.25 pixels); 80 N's rows need about 1/cos(80) = 5.8 times finer: level 8.
  EXPECT_EQ(composeLevel(g, Sector{box.west, 79.8, box.east, 80.2}, w, 1, 0), 5);
  EXPECT_EQ(canvas[2] / 10, 8);
  EXPECT_EQ(canvas[static_cast<std::size_t>((h - 1) * w * 4 + 2)] / 10, 8);
}

// The one-plane path (a JPEG map's Y, Cb, Cr) and a picture over a transparent canvas: past the
// square the background (plane) or nothing drawn (canvas).
TEST(WebMercator, PastTheSquareIsBackgroundOrNothing) {
  const auto g = grid(32, 6);
  const LatitudeTiles picture(g, LatitudeTiles::Kind::Rgb);
  const MapBox box = mercatorBox(Sector{-2.0e6, kMaxY - 4.0e6, 2.0e6, kMaxY + 4.0e6});
  const std::int32_t w = 32, h = 64;
  const LatitudeTiles greens(g, LatitudeTiles::Kind::Green);
  const auto bands = composeBands(g, box, w, h, 0);
  std::vector<std::uint8_t> canvas(static_cast<std::size_t>(w * h * 4), 0);
  std::vector<std::uint8_t> plane(static_cast<std::size_t>(w * h), 0);
  for (const ComposeBand& b : bands) {
    composeImagery(g, b.box, w, h, b.level, 0, picture.lookup(), 1.0, canvas);
    composePlane(g, b.box, w, h, b.level, 0, greens.lookup(), 200, plane);
  }
  for (std::int32_t j = 0; j < h; ++j) {
    const double y = rowY(box, j, h);
    const auto at = static_cast<std::size_t>(j * w + 5);
    if (y > kMaxY) {
      EXPECT_EQ(canvas[at * 4 + 3], 0) << j;
      EXPECT_EQ(plane[at], 200) << j;
    } else {
      EXPECT_EQ(canvas[at * 4 + 3], 255) << j;
      EXPECT_NEAR(plane[at], 255.0 * (90.0 - latitudeOfY(y)) / 180.0, 1.01) << j;
      EXPECT_EQ(plane[at], canvas[at * 4 + 1]) << j;
    }
  }
}

// A box across the antimeridian (x past pi R) wraps around a global layer as a lon/lat one does.
TEST(WebMercator, AntimeridianWraps) {
  const auto g = grid(32, 4);
  const LatitudeTiles tiles(g, LatitudeTiles::Kind::Values);
  const MapBox across = mercatorBox(Sector{kMaxY - 5.0e5, 0.0, kMaxY + 5.0e5, 1.0e6});
  const auto v = composeAllBands(g, across, 40, 40, tiles.lookup());
  for (float f : v)
    EXPECT_FALSE(std::isnan(f));
  const auto bands = composeBands(g, across, 40, 40, 0);
  const auto keys = composeTiles(g, bands.front().box, 40, 40, bands.front().level, 1000);
  ASSERT_TRUE(keys.has_value());
  bool west = false, east = false;
  for (const auto& k : *keys) {
    west = west || k.key.col == 0;
    east = east || k.key.col == g.colCount(k.key.level) - 1;
  }
  EXPECT_TRUE(west && east);
}

// ---- WMS ----------------------------------------------------------------------------------------

namespace {

std::expected<WmsRequest, OgcException> wms(const std::string& query) {
  const auto q = parseQuery(query);
  EXPECT_TRUE(q.has_value()) << query;
  if (!q) return std::unexpected(OgcException{"query", "", q.error()});
  return parseWms(*q, WmsLimits{});
}

const std::string kMap = "SERVICE=WMS&REQUEST=GetMap&LAYERS=a&STYLES=&WIDTH=256&HEIGHT=256"
                         "&FORMAT=image/png";

} // namespace

// EPSG:3857 and its aliases (any case) are EPSG:3857, easting then northing under both versions.
TEST(WebMercatorWms, AliasesAndAxisOrder) {
  for (const std::string crs :
       {"EPSG:3857", "epsg:3857", "EPSG:900913", "EPSG:102100", "EPSG:102113"}) {
    for (const std::string v : {"VERSION=1.3.0&CRS=", "VERSION=1.1.1&SRS="}) {
      const auto r = wms(kMap + "&" + v + crs + "&BBOX=-1000,2000,3000,5000");
      ASSERT_TRUE(r.has_value()) << crs << " " << r.error().message;
      const auto& m = std::get<GetMapRequest>(*r);
      EXPECT_EQ(m.crs, "EPSG:3857");
      EXPECT_EQ(m.bbox, (Sector{-1000, 2000, 3000, 5000})) << v;
      const MapBox b = mapBoxOf(m);
      EXPECT_EQ(b.rows, MapRows::Mercator);
      EXPECT_DOUBLE_EQ(b.northY, 5000);
      EXPECT_DOUBLE_EQ(b.southY, 2000);
      EXPECT_NEAR(b.west, longitudeOfX(-1000), 1e-15);
    }
  }
  // EPSG:4326 under 1.3.0 stays latitude first.
  const auto latLon = wms(kMap + "&VERSION=1.3.0&CRS=EPSG:4326&BBOX=-10,20,30,40");
  ASSERT_TRUE(latLon.has_value());
  EXPECT_EQ(std::get<GetMapRequest>(*latLon).bbox, (Sector{20, -10, 40, 30}));
  EXPECT_EQ(mapBoxOf(std::get<GetMapRequest>(*latLon)).rows, MapRows::Latitude);
  // A box past the square (and the whole world and more) is valid: its outside is empty.
  EXPECT_TRUE(wms(kMap + "&VERSION=1.3.0&CRS=EPSG:3857&BBOX=-4e7,-4e7,4e7,4e7").has_value());
  // Min not below max: InvalidParameterValue.
  const auto bad = wms(kMap + "&VERSION=1.3.0&CRS=EPSG:3857&BBOX=0,10,0,20");
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, "InvalidParameterValue");
}

TEST(WebMercatorWms, OtherCrsAreStillInvalid) {
  const auto v130 = wms(kMap + "&VERSION=1.3.0&CRS=EPSG:32633&BBOX=0,0,1,1");
  ASSERT_FALSE(v130.has_value());
  EXPECT_EQ(v130.error().code, "InvalidCRS");
  EXPECT_NE(v130.error().message.find("EPSG:3857"), std::string::npos);
  const auto v111 = wms(kMap + "&VERSION=1.1.1&SRS=EPSG:3395&BBOX=0,0,1,1");
  ASSERT_FALSE(v111.has_value());
  EXPECT_EQ(v111.error().code, "InvalidSRS");
  EXPECT_FALSE(isWebMercator("EPSG:38570"));
}

// Both versions advertise EPSG:3857 and give each layer a box in metres, clamped to the square.
TEST(WebMercatorWms, CapabilitiesAdvertiseIt) {
  CapabilitiesModel m;
  m.title = "t";
  m.onlineResource = "http://localhost/wms?";
  m.getMapFormats = {"image/png"};
  CapabilitiesLayer world;
  world.name = "world";
  world.title = "world";
  world.bbox = Sector{-180, -90, 180, 90};
  CapabilitiesLayer part;
  part.name = "part";
  part.title = "part";
  part.bbox = Sector{0, 0, 90, 45};
  m.layers = {world, part};
  const std::string c130 = capabilitiesXml(WmsVersion::V130, m);
  EXPECT_NE(c130.find("<CRS>EPSG:3857</CRS>"), std::string::npos);
  const std::string worldBox =
      "minx=\"" + formatCoordinate(-kMaxY) + "\" miny=\"" + formatCoordinate(-kMaxY) + "\"";
  EXPECT_NE(c130.find("<BoundingBox CRS=\"EPSG:3857\" " + worldBox), std::string::npos) << c130;
  EXPECT_NE(c130.find("<BoundingBox CRS=\"EPSG:3857\" minx=\"0\" miny=\"0\" maxx=\"" +
                      formatCoordinate(kMaxY / 2) + "\" maxy=\"" +
                      formatCoordinate(yOfLatitude(45.0)) + "\"/>"),
            std::string::npos)
      << c130;
  const std::string c111 = capabilitiesXml(WmsVersion::V111, m);
  EXPECT_NE(c111.find("<SRS>EPSG:3857</SRS>"), std::string::npos);
  EXPECT_NE(c111.find("<BoundingBox SRS=\"EPSG:3857\" " + worldBox), std::string::npos) << c111;
}
