// parseWmtsKvpQuery (Wmts.hpp), the one-pass KVP parse of the WMTS front end: for every query it
// takes, the answer of parseQuery and parseWmtsKvp; the queries it leaves to them (escapes, '+',
// NUL, a WMTS name twice, the limits) are left.
#include <tellus/proxy/Wmts.hpp>

#include <gtest/gtest.h>

using namespace tellus;

namespace {

constexpr std::size_t kParam = 64;
constexpr std::size_t kQuery = 4096;

/** What the front end's general path answers: parseQuery's error as an InvalidParameterValue. */
std::expected<WmtsRequest, OgcException> general(std::string_view q) {
  auto params = parseQuery(q, kParam, kQuery);
  if (!params) return std::unexpected(OgcException{"InvalidParameterValue", "", params.error()});
  return parseWmtsKvp(*params);
}

const std::string kTile = "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=default"
                          "&FORMAT=image/jpeg&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=3&TILEROW=2"
                          "&TILECOL=5";

} // namespace

TEST(WmtsKvpQuery, AgreesWithTheGeneralPathOnTheQueriesItTakes) {
  const std::vector<std::string> queries = {
      kTile,
      "?" + kTile,
      kTile + "&TIME=2024-01-01",
      kTile + "&time=",
      kTile + "&&unknown=1&=x&flag",
      "service=wmts&request=gettile&version=1.0.0&layer=sat&style=&format=image/jpeg"
      "&tilematrixset=WorldWind_sat&tilematrix=3&tilerow=2&tilecol=5",
      "SeRvIcE=WMTS&REQUEST=GetCapabilities",
      "SERVICE=WMTS&REQUEST=GetCapabilities&ACCEPTVERSIONS=2.0.0,1.0.0",
      "SERVICE=WMTS&REQUEST=GetCapabilities&ACCEPTVERSIONS=2.0.0",
      "SERVICE=WMTS&REQUEST=GetFeatureInfo",
      "SERVICE=WMS&REQUEST=GetTile",
      "REQUEST=GetTile",
      "SERVICE",
      "",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.1.0",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=&FORMAT=image/png"
      "&TILEMATRIXSET=s&TILEMATRIX=0&TILEROW=-1&TILECOL=0",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=&FORMAT=image/png"
      "&TILEMATRIXSET=s&TILEMATRIX=0&TILEROW=0&TILECOL=x1",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=&FORMAT=image/png"
      "&TILEMATRIXSET=s&TILEMATRIX=0&TILEROW=0&TILECOL=1&TILEMATRIXSETS=x&TILECOLS=2&LAYERS=y",
      "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=s\xc3\xa4t&STYLE=&FORMAT=image/png"
      "&TILEMATRIXSET=s&TILEMATRIX=0&TILEROW=0&TILECOL=1",
  };
  for (const std::string& q : queries) {
    SCOPED_TRACE(q);
    const auto quick = parseWmtsKvpQuery(q, kParam, kQuery);
    ASSERT_TRUE(quick.has_value());
    const auto expected = general(q);
    ASSERT_EQ(quick->has_value(), expected.has_value());
    if (expected) {
      EXPECT_EQ(**quick, *expected);
    } else {
      EXPECT_EQ(quick->error().code, expected.error().code);
      EXPECT_EQ(quick->error().locator, expected.error().locator);
      EXPECT_EQ(quick->error().message, expected.error().message);
    }
  }
}

TEST(WmtsKvpQuery, LeavesEscapesRepeatsAndLimitsToTheGeneralPath) {
  using namespace std::string_literals;
  for (const std::string& q : {kTile + "&TIME=2024%2D01",
                               kTile + "&x=a+b",
                               kTile + "&x=a\0b"s,
                               kTile + "&LAYER=sat",
                               kTile + "&layer=other",
                               kTile + "&x=" + std::string(kParam + 1, 'a'),
                               kTile + "&" + std::string(kParam + 1, 'a') + "=1",
                               kTile + std::string(kQuery, '&'),
                               [] {
                                 std::string many = kTile;
                                 for (std::size_t i = 0; i < kMaxQueryParams; ++i)
                                   many += "&p=1";
                                 return many;
                               }()}) {
    SCOPED_TRACE(q);
    EXPECT_FALSE(parseWmtsKvpQuery(q, kParam, kQuery).has_value());
  }
}
