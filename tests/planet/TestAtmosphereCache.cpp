// The atmosphere's tables on disk (planet/AtmosphereCache.hpp): a round trip, a file that is
// truncated, corrupt or of another atmosphere is recomputed (never trusted), the key covers every
// parameter and size, and a folder that cannot be written still gives the tables. Small tables
// (a few milliseconds to compute) stand in for the real ones.
#include "../support/TempDir.hpp"

#include <tellus/planet/AtmosphereCache.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <vector>

namespace {

using namespace tellus::planet;
namespace fs = std::filesystem;

AtmosphereTableSizes small() {
  AtmosphereTableSizes s;
  s.transmittanceW = 16;
  s.transmittanceH = 8;
  s.scatteringR = 4;
  s.scatteringMu = 8;
  s.scatteringMuS = 4;
  s.scatteringNu = 4;
  s.multipleW = 4;
  s.multipleH = 4;
  s.samples = 4;
  return s;
}

void expectSame(const AtmosphereTables& a, const AtmosphereTables& b) {
  EXPECT_EQ(a.transmittanceTable(), b.transmittanceTable());
  EXPECT_EQ(a.scatteringTable(), b.scatteringTable());
  EXPECT_EQ(a.mieTable(), b.mieTable());
  EXPECT_EQ(a.multipleTable(), b.multipleTable());
}

std::vector<fs::path> filesIn(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    out.push_back(e.path());
  return out;
}

TEST(AtmosphereCache, ComputesOnceThenReadsTheSameTables) {
  tellus::test::TempDir dir("atmo-cache");
  const AtmosphereParameters p;
  const AtmosphereCacheResult first = cachedAtmosphereTables(dir.path() / "sub", p, small(), 1);
  EXPECT_FALSE(first.fromCache);
  ASSERT_TRUE(fs::exists(atmosphereCacheFile(dir.path() / "sub", p, small())));
  EXPECT_EQ(filesIn(dir.path() / "sub").size(), 1u); // no temporary file left behind
  const AtmosphereCacheResult second = cachedAtmosphereTables(dir.path() / "sub", p, small(), 1);
  EXPECT_TRUE(second.fromCache) << second.note;
  expectSame(first.tables, second.tables);
  EXPECT_EQ(second.tables.sizes().scatteringMu, small().scatteringMu);
  // The same values as computing them.
  expectSame(second.tables, AtmosphereTables::precompute(p, small(), 1));
}

TEST(AtmosphereCache, ATruncatedFileIsRecomputedAndRewritten) {
  tellus::test::TempDir dir("atmo-cache");
  const AtmosphereParameters p;
  const fs::path file = atmosphereCacheFile(dir.path(), p, small());
  const AtmosphereTables good = cachedAtmosphereTables(dir.path(), p, small(), 1).tables;
  const auto size = fs::file_size(file);
  for (std::uintmax_t keep : {std::uintmax_t{0}, std::uintmax_t{5}, size / 2, size - 1}) {
    fs::resize_file(file, keep);
    EXPECT_FALSE(loadAtmosphereTables(file, p, small()).has_value()) << keep;
    const AtmosphereCacheResult r = cachedAtmosphereTables(dir.path(), p, small(), 1);
    EXPECT_FALSE(r.fromCache) << keep;
    EXPECT_NE(r.note, "") << keep;
    expectSame(r.tables, good);
    EXPECT_EQ(fs::file_size(file), size) << "rewritten whole";
  }
  // A file with bytes appended is refused too.
  { std::ofstream(file, std::ios::binary | std::ios::app) << "x"; }
  EXPECT_FALSE(loadAtmosphereTables(file, p, small()).has_value());
}

TEST(AtmosphereCache, ACorruptByteIsCaught) {
  tellus::test::TempDir dir("atmo-cache");
  const AtmosphereParameters p;
  const fs::path file = atmosphereCacheFile(dir.path(), p, small());
  (void)cachedAtmosphereTables(dir.path(), p, small(), 1);
  const auto size = fs::file_size(file);
  for (std::uintmax_t at : {std::uintmax_t{0}, std::uintmax_t{20}, size / 2, size - 3}) {
    std::fstream f(file, std::ios::binary | std::ios::in | std::ios::out);
    f.seekg(static_cast<std::streamoff>(at));
    char c = 0;
    f.get(c);
    f.seekp(static_cast<std::streamoff>(at));
    f.put(static_cast<char>(c ^ 0x10));
    f.close();
    const auto loaded = loadAtmosphereTables(file, p, small());
    EXPECT_FALSE(loaded.has_value()) << "byte " << at;
    f.open(file, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(static_cast<std::streamoff>(at));
    f.put(c);
  }
  EXPECT_TRUE(loadAtmosphereTables(file, p, small()).has_value());
}

TEST(AtmosphereCache, TheKeyCoversEveryParameterAndSize) {
  std::vector<AtmosphereParameters> ps(14);
  ps[1].bottomRadiusM += 1.0;
  ps[2].topAltitudeM += 1.0;
  ps[3].rayleighScattering.z *= 1.001;
  ps[4].rayleighScaleHeightM += 1.0;
  ps[5].mieScattering *= 1.001;
  ps[6].mieExtinction *= 1.001;
  ps[7].mieScaleHeightM += 1.0;
  ps[8].miePhaseG = 0.7;
  ps[9].ozoneAbsorption.x *= 1.001;
  ps[10].ozoneCentreM += 1.0;
  ps[11].solarIrradiance.y *= 1.001;
  ps[12].groundAlbedo = glm::dvec3(0.3);
  ps[13].muSMin = -0.25;
  std::set<std::string> keys;
  for (const AtmosphereParameters& p : ps)
    keys.insert(atmosphereCacheKey(p, {}));
  AtmosphereTableSizes s;
  s.scatteringMuS = 64;
  keys.insert(atmosphereCacheKey({}, s));
  s = {};
  s.samples = 40;
  keys.insert(atmosphereCacheKey({}, s));
  EXPECT_EQ(keys.size(), ps.size() + 2);
  EXPECT_EQ(atmosphereCacheKey({}, {}).size(), 16u);
  // Another atmosphere's file in this one's place (a collision, or a copied file) is refused.
  tellus::test::TempDir dir("atmo-cache");
  AtmosphereParameters other;
  other.miePhaseG = 0.7;
  ASSERT_TRUE(
      saveAtmosphereTables(AtmosphereTables::precompute(other, small(), 1), dir.path() / "f.bin"));
  EXPECT_FALSE(loadAtmosphereTables(dir.path() / "f.bin", AtmosphereParameters{}, small()));
  EXPECT_TRUE(loadAtmosphereTables(dir.path() / "f.bin", other, small()));
}

TEST(AtmosphereCache, AFolderThatCannotBeWrittenStillGivesTheTables) {
  tellus::test::TempDir dir("atmo-cache");
  std::ofstream(dir.path() / "file") << "not a folder";
  const AtmosphereCacheResult r = cachedAtmosphereTables(
      dir.path() / "file" / "atmosphere", AtmosphereParameters{}, small(), 1);
  EXPECT_FALSE(r.fromCache);
  EXPECT_NE(r.note.find("cannot"), std::string::npos) << r.note;
  EXPECT_FALSE(r.tables.scatteringTable().empty());
  // No folder at all: computed, nothing written.
  EXPECT_FALSE(cachedAtmosphereTables({}, AtmosphereParameters{}, small(), 1).fromCache);
}

} // namespace
