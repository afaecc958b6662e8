// VESA MPCDI read into channels (issue 28; mpcdi/include/tellus/mpcdi/Mpcdi.hpp): the five-channel
// dome written as a "3d" calibration parses into the JSON configuration's channels with warps that
// change nothing; alpha maps and their gamma; the "2d" profile over a domemaster; coordinateFrame;
// off-axis frusta; and every malformed file refused with the file and what is wrong.

#include "../codec/CodecTestSupport.hpp"
#include "MpcdiWriter.hpp"

#include <tellus/codec/Png.hpp>
#include <tellus/mpcdi/Mpcdi.hpp>
#include <tellus/planet/ChannelWarp.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

namespace tellus::mpcdi {
namespace {

namespace fs = std::filesystem;
using test::domeEntries;
constexpr double kDeg = std::numbers::pi / 180.0;

fs::path tmp(const std::string& name) {
  const fs::path dir = fs::path(TELLUS_TEST_TMP_DIR) / "mpcdi";
  fs::create_directories(dir);
  return dir / name;
}

fs::path zip(const std::string& name, const std::map<std::string, std::string>& entries) {
  const fs::path f = tmp(name);
  test::writeZip(f, entries);
  return f;
}

/** The message of a refused file, or "" when it was read. */
std::string refusal(const fs::path& f) {
  const auto r = readMpcdi(f);
  return r ? std::string() : r.error();
}

double angleDeg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) / kDeg;
}

/** The direction a projector pixel shows through the channel's warp mesh (ChannelWarp.hpp's map).
 */
glm::dvec3 shown(const planet::Channel& c, double px, double py) {
  const planet::WarpMesh& m = *c.warpMesh;
  const double gx = std::clamp(px / c.width * (m.columns - 1), 0.0, m.columns - 1.0);
  const double gy = std::clamp(py / c.height * (m.rows - 1), 0.0, m.rows - 1.0);
  const int i0 = std::min(static_cast<int>(gx), m.columns - 2);
  const int j0 = std::min(static_cast<int>(gy), m.rows - 2);
  const double fx = gx - i0, fy = gy - j0;
  auto v = [&](int i, int j) { return m.uv[static_cast<std::size_t>(j * m.columns + i)]; };
  const glm::dvec2 uv = (v(i0, j0) * (1 - fx) + v(i0 + 1, j0) * fx) * (1 - fy) +
                        (v(i0, j0 + 1) * (1 - fx) + v(i0 + 1, j0 + 1) * fx) * fy;
  return planet::channelPixelDirection(c, {uv.x * c.width, uv.y * c.height});
}

TEST(Pfm, ReadsRowsFromTheTopInEitherByteOrder) {
  const std::vector<float> xyz{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}; // 2 x 2, top row first
  auto little = parsePfm(test::pfm(2, 2, xyz), "a.pfm");
  ASSERT_TRUE(little) << little.error();
  EXPECT_EQ(little->width, 2);
  EXPECT_EQ(little->xyz, xyz);
  // Big-endian: a positive scale.
  std::string big = "PF\n2 2\n1.0\n";
  for (int y = 1; y >= 0; --y)
    for (int i = 0; i < 6; ++i) {
      const float f = xyz[static_cast<std::size_t>(y * 6 + i)];
      unsigned char b[4];
      std::memcpy(b, &f, 4);
      big.append({static_cast<char>(b[3]),
                  static_cast<char>(b[2]),
                  static_cast<char>(b[1]),
                  static_cast<char>(b[0])});
    }
  auto be = parsePfm(big, "b.pfm");
  ASSERT_TRUE(be) << be.error();
  EXPECT_EQ(be->xyz, xyz);
}

TEST(Pfm, RefusesMalformedOnes) {
  const std::string good = test::pfm(2, 2, std::vector<float>(12, 0.5f));
  auto error = [](const std::string& bytes) {
    const auto r = parsePfm(bytes, "w.pfm");
    return r ? std::string() : r.error();
  };
  EXPECT_EQ(error(good), "");
  EXPECT_EQ(error("P6\n2 2\n255\n"), "w.pfm: not a PFM (it must begin with \"PF\")");
  EXPECT_NE(error("Pf\n2 2\n-1.0\n" + std::string(16, '\0')).find("grey PFM"), std::string::npos);
  EXPECT_NE(error("PF\n2 x\n-1.0\n").find("PFM header: width and height"), std::string::npos);
  EXPECT_NE(error("PF\n2 2\n0\n").find("the scale must be"), std::string::npos);
  EXPECT_EQ(error(good.substr(0, good.size() - 5)),
            "w.pfm: truncated: 43 bytes of texels, 2 x 2 needs 48");
  EXPECT_EQ(error(good + "xxxx"),
            "w.pfm: the size disagrees with the data: 2 x 2 needs 48 bytes of texels, the file "
            "has 52");
  std::vector<float> inf(12, 0.5f);
  inf[4] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(error(test::pfm(2, 2, inf)), "w.pfm: texel (1, 0) from the top left is infinite");
}

TEST(Mpcdi, TheFiveChannelDomeIsTheJsonConfigurationsChannels) {
  const auto channels = readMpcdi(zip("dome.mpcdi", domeEntries(1, 21, false)));
  ASSERT_TRUE(channels) << channels.error();
  const auto json = test::fiveChannelDome(1);
  ASSERT_EQ(channels->size(), json.size());
  for (std::size_t i = 0; i < json.size(); ++i) {
    const planet::Channel &c = (*channels)[i], &j = json[i];
    EXPECT_EQ(c.name, j.name);
    EXPECT_NEAR(std::remainder(c.azimuthDeg - j.azimuthDeg, 360.0), 0.0, 1e-9) << c.name;
    EXPECT_NEAR(c.elevationDeg, j.elevationDeg, 1e-9);
    EXPECT_NEAR(c.hfovDeg, j.hfovDeg, 1e-9);
    EXPECT_NEAR(c.vfovDeg, j.vfovDeg, 1e-9);
    EXPECT_NEAR(c.rollDeg, j.rollDeg, 1e-9);
    EXPECT_EQ(c.width, j.width);
    EXPECT_EQ(c.height, j.height);
    // Same frame, so the same pixels in the same directions.
    const planet::ChannelFrame a = planet::channelFrame(c), b = planet::channelFrame(j);
    EXPECT_LT(angleDeg(a.forward, b.forward), 1e-9);
    EXPECT_LT(angleDeg(a.up, b.up), 1e-9);
    // The warp: 21 x 15 texels of 3D points; every projector pixel shows its own direction.
    ASSERT_TRUE(c.warpMesh);
    EXPECT_EQ(c.warpMesh->columns, 21);
    EXPECT_EQ(c.warpMesh->rows, 15);
    EXPECT_FALSE(c.blendMask) << "no alpha map, no gaps: no mask";
    for (const auto& [px, py] : {std::pair{0.5, 0.5}, {50.0, 35.0}, {99.5, 69.5}, {13.25, 61.0}}) {
      const double x = px * c.width / 100.0, y = py * c.height / 70.0;
      EXPECT_LT(angleDeg(shown(c, x, y), planet::channelPixelDirection(j, {x, y})), 1e-4)
          << c.name << " " << x << "," << y;
    }
  }
}

TEST(Mpcdi, TheIdentityWarpChangesNoPixel) {
  const auto channels = readMpcdi(zip("dome-px.mpcdi", domeEntries(1, 9, false)));
  ASSERT_TRUE(channels) << channels.error();
  const planet::Channel& c = channels->front();
  planet::ChannelImage image{c.width, c.height, {}};
  for (int i = 0; i < c.width * c.height * 4; ++i)
    image.rgba.push_back(static_cast<std::uint8_t>((i * 37 + i / 400 * 11) % 251));
  const auto out = planet::warpAndBlend(image, c.width, c.height, c.warpMesh.get(), nullptr);
  EXPECT_EQ(out.rgba, image.rgba);
}

TEST(Mpcdi, AlphaMapsAreTheBlendMaskTheirGammaUndone) {
  const planet::Channel c = test::fiveChannelDome(1).front();
  const auto n = static_cast<std::size_t>(c.width * c.height);
  auto withAlpha = [&](const std::string& name, const std::string& png, double gamma) {
    auto e = std::map<std::string, std::string>{
        {"w.pfm", test::pfm(3, 2, test::identityWarp3d(c, 3, 2))},
        {"a.png", png},
        {"mpcdi.xml",
         test::documentXml(
             "3d", test::regionXml(c), test::filesetXml(c.name, "w.pfm", "a.png", gamma))}};
    return readMpcdi(zip(name, e));
  };
  auto png = [](int w, int h, int channels, const std::vector<std::uint8_t>& p) {
    const auto b = codec::encodePng(w, h, channels, p.data());
    return std::string(reinterpret_cast<const char*>(b->data()), b->size());
  };
  // 8-bit grey, gamma 2.2 (the PNGs' own): the stored value is the weight.
  auto a = withAlpha("a8.mpcdi", png(c.width, c.height, 1, std::vector<std::uint8_t>(n, 128)), 2.2);
  ASSERT_TRUE(a) << a.error();
  ASSERT_TRUE(a->front().blendMask);
  EXPECT_NEAR((*a->front().blendMask)[77], 128.0 / 255.0, 1e-6);
  // Gamma 1 (linear light): the weight on the PNG's values is stored ^ (1 / 2.2).
  auto l = withAlpha("a1.mpcdi", png(c.width, c.height, 1, std::vector<std::uint8_t>(n, 128)), 1.0);
  ASSERT_TRUE(l) << l.error();
  EXPECT_NEAR((*l->front().blendMask)[77], std::pow(128.0 / 255.0, 1.0 / 2.2), 1e-6);
  // Half the size: resampled to the projector's pixels. RGB: the first channel.
  std::vector<std::uint8_t> rgb(n / 4 * 3, 0);
  for (std::size_t i = 0; i < rgb.size(); i += 3)
    rgb[i] = 255;
  auto h = withAlpha("ah.mpcdi", png(c.width / 2, c.height / 2, 3, rgb), 2.2);
  ASSERT_TRUE(h) << h.error();
  EXPECT_EQ(h->front().blendMask->size(), n);
  EXPECT_NEAR((*h->front().blendMask)[n / 2], 1.0, 1e-6);
  // 16-bit grey, read as stored (not reduced to 8 bits first).
  const auto b16 =
      tellus::test::handWrittenPng(c.width, c.height, 16, 0, std::vector<std::uint16_t>(n, 40000));
  auto s = withAlpha(
      "a16.mpcdi", std::string(reinterpret_cast<const char*>(b16.data()), b16.size()), 2.2);
  ASSERT_TRUE(s) << s.error();
  EXPECT_NEAR((*s->front().blendMask)[5], 40000.0 / 65535.0, 1e-6);
}

TEST(Mpcdi, TheTwoDimensionalProfileMapsProjectorPixelsOntoTheDomemaster) {
  // The 2D media profile: each texel is a point of the buffer, read as the domemaster (angular
  // fisheye of 180 degrees, its top the azimuth 0). A projector looking at azimuth 30, elevation
  // 40 through a 60 x 45 degree view: its texels' directions written as domemaster points.
  planet::Channel truth;
  truth.azimuthDeg = 30;
  truth.elevationDeg = 40;
  truth.hfovDeg = 60;
  truth.vfovDeg = 2 * std::atan(std::tan(30 * kDeg) * 0.75) / kDeg;
  truth.width = 160;
  truth.height = 120;
  const int w = 17, h = 13;
  std::vector<float> xy;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const glm::dvec3 d = planet::channelPixelDirection(
          truth, {(i + 0.5) / w * truth.width, (j + 0.5) / h * truth.height});
      const double el = std::asin(-d.z) / kDeg, az = std::atan2(d.x, d.y);
      const double r = 1.0 - el / 90.0;
      xy.insert(xy.end(),
                {static_cast<float>(0.5 + 0.5 * r * std::sin(az)),
                 static_cast<float>(0.5 - 0.5 * r * std::cos(az)),
                 0.0f});
    }
  const std::string region = "<region id=\"p 1\" xResolution=\"160\" yResolution=\"120\"/>";
  const auto channels = readMpcdi(
      zip("2d.mpcdi",
          {{"p1.pfm", test::pfm(w, h, xy)},
           {"mpcdi.xml", test::documentXml("2d", region, test::filesetXml("p 1", "p1.pfm"))}}));
  ASSERT_TRUE(channels) << channels.error();
  const planet::Channel& c = channels->front();
  EXPECT_EQ(c.name, "p_1");
  EXPECT_EQ(c.width, 160);
  EXPECT_EQ(c.height, 120);
  EXPECT_LT(angleDeg(planet::channelFrame(c).forward, planet::channelFrame(truth).forward), 2.0);
  EXPECT_LE(c.hfovDeg, 75.0);
  for (const auto& [x, y] : {std::pair{0.5, 0.5}, {80.0, 60.0}, {159.5, 119.5}, {20.0, 100.0}})
    EXPECT_LT(angleDeg(shown(c, x, y), planet::channelPixelDirection(truth, {x, y})), 0.05)
        << x << "," << y;
}

TEST(Mpcdi, CoordinateFrameAndOffAxisFrusta) {
  // Mystique's "surveyor" frame (z up, y forward, x right: the yaw axis points down -z) and an
  // off-axis frustum (10 degrees more to the right than to the left, the same up and down).
  planet::Channel sym = test::fiveChannelDome(1)[1]; // east
  const int w = 11, h = 9;
  // The projector: its frustum from -45 to 65 degrees across; its pixel x shows the direction at
  // tan = tan(-45) + (tan(65) - tan(-45)) * x / width across, as a pinhole does.
  const double tl = std::tan(-45 * kDeg), tr = std::tan(65 * kDeg), tu = std::tan(45 * kDeg);
  const planet::ChannelFrame f = planet::channelFrame(sym);
  auto direction = [&](double px, double py) {
    const double x = tl + (tr - tl) * px / sym.width;
    const double y = tu - 2 * tu * py / sym.height;
    return glm::normalize(f.forward + x * f.right + y * f.up);
  };
  std::vector<float> xyz;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const glm::dvec3 d = direction((i + 0.5) / w * sym.width, (j + 0.5) / h * sym.height);
      // MPCDI right, up, forward = (-d.x, -d.z, d.y); in the surveyor frame x = right, y =
      // forward, z = up; the eye at (1, 2, 3).
      for (const double v : {-d.x + 1, d.y + 2, -d.z + 3})
        xyz.push_back(static_cast<float>(v));
    }
  const std::string region =
      "<region id=\"east\" xResolution=\"100\" yResolution=\"70\"><frustum><yaw>-90</yaw>"
      "<pitch>20</pitch><roll>0</roll><rightAngle>65</rightAngle><leftAngle>-45</leftAngle>"
      "<upAngle>45</upAngle><downAngle>-45</downAngle></frustum><coordinateFrame>"
      "<posx>1</posx><posy>2</posy><posz>3</posz><yawx>0</yawx><yawy>0</yawy><yawz>-1</yawz>"
      "<pitchx>1</pitchx><pitchy>0</pitchy><pitchz>0</pitchz><rollx>0</rollx><rolly>1</rolly>"
      "<rollz>0</rollz></coordinateFrame></region>";
  const auto channels = readMpcdi(
      zip("frame.mpcdi",
          {{"e.pfm", test::pfm(w, h, xyz)},
           {"mpcdi.xml", test::documentXml("3d", region, test::filesetXml("east", "e.pfm"))}}));
  ASSERT_TRUE(channels) << channels.error();
  const planet::Channel& c = channels->front();
  EXPECT_LT(angleDeg(planet::channelFrame(c).forward, f.forward), 1e-9);
  EXPECT_NEAR(c.hfovDeg, 130.0, 1e-9); // the symmetric view that holds 65 degrees to each side
  EXPECT_EQ(c.width, 100);
  EXPECT_NEAR(std::tan(c.hfovDeg * kDeg / 2) / std::tan(c.vfovDeg * kDeg / 2), 100.0 / 70, 1e-9);
  for (const auto& [x, y] : {std::pair{0.5, 0.5}, {50.0, 35.0}, {99.5, 69.5}, {70.0, 10.0}})
    EXPECT_LT(angleDeg(shown(c, x, y), direction(x, y)), 0.01) << x << "," << y;
}

TEST(Mpcdi, NaNTexelsShowBlackAndPartialOrAllNaNAreRefused) {
  const planet::Channel c = test::fiveChannelDome(1).front();
  auto with = [&](const std::string& name, const std::vector<float>& xyz) {
    return readMpcdi(
        zip(name,
            {{"w.pfm", test::pfm(5, 4, xyz)},
             {"mpcdi.xml",
              test::documentXml("3d", test::regionXml(c), test::filesetXml(c.name, "w.pfm"))}}));
  };
  std::vector<float> xyz = test::identityWarp3d(c, 5, 4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  xyz[0] = xyz[1] = xyz[2] = nan; // the top left texel: no content
  auto gap = with("gap.mpcdi", xyz);
  ASSERT_TRUE(gap) << gap.error();
  ASSERT_TRUE(gap->front().blendMask);
  const auto& mask = *gap->front().blendMask;
  EXPECT_EQ(mask[0], 0.0f) << "the top left corner shows nothing";
  EXPECT_EQ(mask[static_cast<std::size_t>(c.width * c.height - 1)], 1.0f);
  for (const glm::dvec2& v : gap->front().warpMesh->uv)
    EXPECT_TRUE(std::isfinite(v.x));

  xyz = test::identityWarp3d(c, 5, 4);
  xyz[7] = nan; // texel (2, 0): y only
  auto part = with("part.mpcdi", xyz);
  ASSERT_FALSE(part);
  EXPECT_NE(part.error().find("part.mpcdi: mpcdi.xml: region \"north\": texel (2, 0) from the "
                              "top left is NaN in part only"),
            std::string::npos)
      << part.error();
  auto none = with("none.mpcdi", std::vector<float>(60, nan));
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().find("no texel of the warp has content"), std::string::npos);
}

TEST(Mpcdi, MalformedFilesAreRefusedNamingTheFileAndWhatIsWrong) {
  const planet::Channel c = test::fiveChannelDome(1).front();
  const std::string warp = test::pfm(3, 2, test::identityWarp3d(c, 3, 2));
  const std::string doc =
      test::documentXml("3d", test::regionXml(c), test::filesetXml(c.name, "w.pfm"));
  const fs::path text = tmp("text.mpcdi");
  std::ofstream(text) << "<MPCDI/>";
  EXPECT_EQ(refusal(text), text.string() + ": mpcdi.xml: <MPCDI> has no profile"); // unpacked
  EXPECT_EQ(refusal(tmp("absent.mpcdi")), tmp("absent.mpcdi").string() + ": cannot be read");
  const fs::path noXml = zip("noxml.mpcdi", {{"w.pfm", warp}});
  EXPECT_EQ(refusal(noXml), noXml.string() + ": no mpcdi.xml in the archive");
  const fs::path bad = zip("badxml.mpcdi", {{"mpcdi.xml", "<MPCDI><display></MPCDI>"}});
  EXPECT_NE(refusal(bad).find("badxml.mpcdi: mpcdi.xml: not XML: mismatched tag at line 1"),
            std::string::npos)
      << refusal(bad);
  const fs::path noWarp = zip("nowarp.mpcdi", {{"mpcdi.xml", doc}});
  EXPECT_EQ(refusal(noWarp),
            noWarp.string() + ": mpcdi.xml: region \"north\": geometryWarpFile: no w.pfm in "
                              "the archive");
  const fs::path noFile =
      zip("nofileset.mpcdi",
          {{"mpcdi.xml", test::documentXml("3d", test::regionXml(c), "")}, {"w.pfm", warp}});
  EXPECT_EQ(refusal(noFile),
            noFile.string() +
                ": mpcdi.xml: region \"north\": no <fileset region=\"north\"> in <files>");
  const fs::path trunc =
      zip("trunc.mpcdi", {{"mpcdi.xml", doc}, {"w.pfm", warp.substr(0, warp.size() - 4)}});
  EXPECT_EQ(refusal(trunc),
            trunc.string() + ": mpcdi.xml: region \"north\": w.pfm: truncated: 68 bytes of "
                             "texels, 3 x 2 needs 72");
  const fs::path size =
      zip("size.mpcdi", {{"mpcdi.xml", doc}, {"w.pfm", "PF\n3 3\n-1\n" + warp.substr(11)}});
  EXPECT_NE(refusal(size).find("w.pfm: truncated"), std::string::npos) << refusal(size);
  const fs::path longer = zip("longer.mpcdi", {{"mpcdi.xml", doc}, {"w.pfm", warp + "1234"}});
  EXPECT_NE(refusal(longer).find("w.pfm: the size disagrees with the data: 3 x 2 needs 72 "
                                 "bytes of texels, the file has 76"),
            std::string::npos);
  for (const std::string profile : {"a3", "sl", "4d"}) {
    const fs::path p =
        zip("profile.mpcdi",
            {{"mpcdi.xml",
              test::documentXml(profile, test::regionXml(c), test::filesetXml(c.name, "w.pfm"))},
             {"w.pfm", warp}});
    EXPECT_EQ(refusal(p),
              p.string() + ": mpcdi.xml: profile \"" + profile +
                  "\" is not read: tellus reads \"2d\" (2D media) and \"3d\" (3D "
                  "simulation), not \"a3\" (advanced 3D) or \"sl\" (shader lamp)");
  }
  const std::string noFrustum = "<region id=\"north\" xResolution=\"100\" yResolution=\"70\"/>";
  const fs::path nf =
      zip("nofrustum.mpcdi",
          {{"mpcdi.xml", test::documentXml("3d", noFrustum, test::filesetXml(c.name, "w.pfm"))},
           {"w.pfm", warp}});
  EXPECT_EQ(refusal(nf),
            nf.string() + ": mpcdi.xml: region \"north\": no frustum (the 3D "
                          "simulation profile needs one)");
  const fs::path nr =
      zip("nores.mpcdi",
          {{"mpcdi.xml",
            test::documentXml("3d", "<region id=\"north\"/>", test::filesetXml(c.name, "w.pfm"))},
           {"w.pfm", warp}});
  EXPECT_EQ(refusal(nr), nr.string() + ": mpcdi.xml: region \"north\": xResolution: missing");
}

} // namespace
} // namespace tellus::mpcdi
