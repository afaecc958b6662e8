// MPCDI as exporters write it besides the zip (issue 28): an unpacked MPCDI (an mpcdi.xml given
// itself, its warp and alpha files beside it, as Christie's Mystique writes FILE.mpcdi.xml) reads
// as its zip does; its paths stay in its folder; <fileset> elements beside <files> (Mystique 2.3)
// are found; and a Mystique export of the shader-lamp profile (its structure as documented at
// github.com/ChristieDigital/mpcdi, "MPCDI_explained.md"; written here, not copied) is refused by
// its profile, not by a puzzling "not a zip".
#include "MpcdiWriter.hpp"

#include <tellus/mpcdi/Mpcdi.hpp>
#include <tellus/planet/ChannelWarp.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace tellus::mpcdi {
namespace {

namespace fs = std::filesystem;

fs::path folder(const std::string& name, const std::map<std::string, std::string>& entries) {
  const fs::path dir = fs::path(TELLUS_TEST_TMP_DIR) / "mpcdi-unpacked" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const auto& [entry, bytes] : entries)
    std::ofstream(dir / entry, std::ios::binary) << bytes;
  return dir;
}

std::string unpackedRefusal(const fs::path& f) {
  const auto r = readMpcdi(f);
  return r ? std::string() : r.error();
}

} // namespace

TEST(MpcdiUnpacked, AnMpcdiXmlGivenItselfReadsAsItsZip) {
  const auto entries = test::domeEntries(1, 9, true);
  const fs::path zipped = fs::path(TELLUS_TEST_TMP_DIR) / "mpcdi-unpacked" / "dome.mpcdi";
  fs::create_directories(zipped.parent_path());
  test::writeZip(zipped, entries);
  const auto fromZip = readMpcdi(zipped);
  ASSERT_TRUE(fromZip) << fromZip.error();
  const fs::path dir = folder("dome", entries);
  fs::rename(dir / "mpcdi.xml", dir / "dome.mpcdi.xml"); // any name: it is XML, not a zip
  const auto unpacked = readMpcdi(dir / "dome.mpcdi.xml");
  ASSERT_TRUE(unpacked) << unpacked.error();
  ASSERT_EQ(unpacked->size(), fromZip->size());
  for (std::size_t i = 0; i < unpacked->size(); ++i) {
    const planet::Channel &a = (*unpacked)[i], &b = (*fromZip)[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.azimuthDeg, b.azimuthDeg);
    EXPECT_EQ(a.elevationDeg, b.elevationDeg);
    EXPECT_EQ(a.width, b.width);
    ASSERT_TRUE(a.warpMesh && b.warpMesh && a.blendMask && b.blendMask);
    EXPECT_EQ(a.warpMesh->uv, b.warpMesh->uv);
    EXPECT_EQ(*a.blendMask, *b.blendMask);
  }
}

TEST(MpcdiUnpacked, ItsPathsStayInItsFolder) {
  const planet::Channel c = test::fiveChannelDome(1).front();
  const std::string warp = test::pfm(3, 2, test::identityWarp3d(c, 3, 2));
  for (const std::string path : {"../w.pfm", "sub/../../w.pfm", "/etc/passwd"}) {
    const fs::path dir =
        folder("escape",
               {{"mpcdi.xml",
                 test::documentXml("3d", test::regionXml(c), test::filesetXml(c.name, path))}});
    std::ofstream(dir.parent_path() / "w.pfm", std::ios::binary) << warp; // there, but outside
    EXPECT_EQ(unpackedRefusal(dir / "mpcdi.xml"),
              (dir / "mpcdi.xml").string() + ": mpcdi.xml: region \"north\": geometryWarpFile: " +
                  path + ": not a path in the MPCDI's folder");
  }
  const fs::path dir =
      folder("missing",
             {{"mpcdi.xml",
               test::documentXml("3d", test::regionXml(c), test::filesetXml(c.name, "w.pfm"))}});
  EXPECT_EQ(unpackedRefusal(dir / "mpcdi.xml"),
            (dir / "mpcdi.xml").string() +
                ": mpcdi.xml: region \"north\": geometryWarpFile: w.pfm: cannot be read (beside "
                "the mpcdi.xml)");
  // Neither a zip nor XML: said so.
  std::ofstream(dir / "junk.mpcdi") << "junk";
  EXPECT_EQ(unpackedRefusal(dir / "junk.mpcdi"),
            (dir / "junk.mpcdi").string() +
                ": not a zip archive (an .mpcdi file is a zip of mpcdi.xml and its files)");
}

namespace {

// Mystique 2.3 writes one <fileset> per region beside <files> (an empty <files/>), paths empty
// when it sends the warp to the projectors itself, and an <extensionSet>.
std::string mystiqueDocument(const std::string& profile, const std::string& warpPath) {
  const planet::Channel c = test::fiveChannelDome(1).front();
  return "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<MPCDI profile=\"" + profile +
         "\" geometry=\"2\" color=\"1\" date=\"2026-12-03 20:00:00\" version=\"2.0\">\n"
         "<display><buffer id=\"dome.cal\">\n" +
         test::regionXml(c) +
         "</buffer></display>\n<files>\n</files>\n<fileset region=\"north\">"
         "<geometryWarpFile><geometricUnit>m</geometricUnit><originOf3DData>unknown"
         "</originOf3DData><path>" +
         warpPath +
         "</path><interpolation>unknown</interpolation></geometryWarpFile>"
         "<distortionMap><path></path></distortionMap></fileset>\n<extensionSet><extension "
         "Name=\"MystiqueExtension\" hasExternalFiles=\"false\"><GeneratedBy>a test"
         "</GeneratedBy></extension></extensionSet>\n</MPCDI>\n";
}

} // namespace

TEST(MpcdiUnpacked, AMystiqueExportIsReadOrRefusedByItsProfile) {
  const fs::path sl = folder("mystique-sl", {{"show.mpcdi.xml", mystiqueDocument("sl", "")}});
  EXPECT_EQ(unpackedRefusal(sl / "show.mpcdi.xml"),
            (sl / "show.mpcdi.xml").string() +
                ": mpcdi.xml: profile \"sl\" is not read: tellus reads \"2d\" (2D media) and "
                "\"3d\" (3D simulation), not \"a3\" (advanced 3D) or \"sl\" (shader lamp)");
  // The same dialect in the 3D simulation profile with its warp: its fileset found beside <files>.
  const planet::Channel c = test::fiveChannelDome(1).front();
  const fs::path d3 = folder("mystique-3d",
                             {{"show.mpcdi.xml", mystiqueDocument("3d", "north.pfm")},
                              {"north.pfm", test::pfm(5, 4, test::identityWarp3d(c, 5, 4))}});
  const auto read = readMpcdi(d3 / "show.mpcdi.xml");
  ASSERT_TRUE(read) << read.error();
  ASSERT_EQ(read->size(), 1u);
  EXPECT_EQ(read->front().name, "north");
  ASSERT_TRUE(read->front().warpMesh);
  EXPECT_EQ(read->front().warpMesh->columns, 5);
  // Its empty path: refused as a missing warp.
  const fs::path empty = folder("mystique-empty", {{"show.mpcdi.xml", mystiqueDocument("3d", "")}});
  EXPECT_EQ(unpackedRefusal(empty / "show.mpcdi.xml"),
            (empty / "show.mpcdi.xml").string() +
                ": mpcdi.xml: region \"north\": no geometryWarpFile with a <path>");
}

} // namespace tellus::mpcdi
