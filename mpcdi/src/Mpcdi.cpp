// An .mpcdi file read into channels (Mpcdi.hpp): the archive, mpcdi.xml's elements, each region's
// files; the geometry is Regions.cpp's.

#include "Archive.hpp"
#include "Regions.hpp"
#include "Xml.hpp"

#include <tellus/codec/Png.hpp>

#include <glm/geometric.hpp>

#include <charconv>
#include <cmath>
#include <map>
#include <set>
#include <span>

namespace tellus::mpcdi {
namespace {

using detail::Element;

std::unexpected<std::string> fail(const std::string& origin, const std::string& what) {
  return std::unexpected(origin + ": " + what);
}

/** A finite number from TEXT, or a message naming WHAT. */
std::expected<double, std::string> number(const std::string& text, const std::string& what) {
  double v = 0.0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size() ||
      !std::isfinite(v))
    return std::unexpected(what + ": \"" + text + "\" is not a finite number");
  return v;
}

std::expected<double, std::string> childNumber(const Element& e, const char* name) {
  const Element* c = e.child(name);
  if (c == nullptr) return std::unexpected(e.name + ": <" + name + "> missing");
  return number(c->text, e.name + ": " + name);
}

std::expected<int, std::string> resolution(const Element& region, const char* name) {
  const std::string* a = region.attribute(name);
  if (a == nullptr) return std::unexpected(std::string(name) + ": missing");
  int v = 0;
  const auto r = std::from_chars(a->data(), a->data() + a->size(), v);
  if (r.ec != std::errc() || r.ptr != a->data() + a->size() || v < 1 || v > 16384)
    return std::unexpected(std::string(name) + ": \"" + *a + "\" is not an integer in [1, 16384]");
  return v;
}

std::expected<detail::Frustum, std::string> readFrustum(const Element& f) {
  detail::Frustum out;
  for (const auto& [name, field] : {std::pair{"yaw", &out.yaw},
                                    std::pair{"pitch", &out.pitch},
                                    std::pair{"roll", &out.roll},
                                    std::pair{"leftAngle", &out.left},
                                    std::pair{"rightAngle", &out.right},
                                    std::pair{"upAngle", &out.up},
                                    std::pair{"downAngle", &out.down}}) {
    const auto v = childNumber(f, name);
    if (!v) return std::unexpected(v.error());
    *field = *v;
  }
  return out;
}

/** coordinateFrame: the eye's position and the yaw (down), pitch (right) and roll (forward)
 * axes as unit vectors in the warp's coordinates; they must be orthonormal. */
std::expected<detail::Frame, std::string> readFrame(const Element& e) {
  glm::dvec3 pos, yaw, pitch, roll;
  for (const auto& [prefix, v] : {std::pair{"pos", &pos},
                                  std::pair{"yaw", &yaw},
                                  std::pair{"pitch", &pitch},
                                  std::pair{"roll", &roll}})
    for (int k = 0; k < 3; ++k) {
      const auto n = childNumber(e, (std::string(prefix) + "xyz"[k]).c_str());
      if (!n) return std::unexpected(n.error());
      (*v)[k] = *n;
    }
  const auto unit = [](const glm::dvec3& a) { return std::abs(glm::length(a) - 1.0) < 1e-3; };
  if (!unit(yaw) || !unit(pitch) || !unit(roll) || std::abs(glm::dot(yaw, pitch)) > 1e-3 ||
      std::abs(glm::dot(yaw, roll)) > 1e-3 || std::abs(glm::dot(pitch, roll)) > 1e-3)
    return std::unexpected("coordinateFrame: the yaw, pitch and roll axes are not orthonormal");
  return detail::Frame{pos, pitch, -yaw, roll};
}

/** The width and height from a PNG's header (IHDR), so that decodePngGrey can be asked. */
bool pngSize(const std::string& b, int& w, int& h) {
  if (b.size() < 24 || b.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) return false;
  auto be = [&](std::size_t at) {
    return static_cast<int>(
        (static_cast<unsigned char>(b[at]) << 24) | (static_cast<unsigned char>(b[at + 1]) << 16) |
        (static_cast<unsigned char>(b[at + 2]) << 8) | static_cast<unsigned char>(b[at + 3]));
  };
  w = be(16);
  h = be(20);
  return w > 0 && h > 0;
}

/** An alpha map: an 8- or 16-bit grey PNG read as stored, or a colour one's first channel. */
std::expected<detail::Alpha, std::string> readAlpha(const std::string& png, double gamma) {
  detail::Alpha a;
  a.gammaEmbedded = gamma;
  if (!pngSize(png, a.width, a.height)) return std::unexpected("not a PNG");
  const auto bytes = std::as_bytes(std::span(png.data(), png.size()));
  if (auto grey = codec::decodePngGrey(bytes, a.width, a.height)) {
    const double full = grey->bitDepth == 16 ? 65535.0 : 255.0;
    a.stored.reserve(grey->samples.size());
    for (const std::uint16_t s : grey->samples)
      a.stored.push_back(static_cast<float>(s / full));
    return a;
  }
  auto rgba = codec::decodePng(bytes);
  if (!rgba) return std::unexpected(rgba.error());
  const auto n = static_cast<std::size_t>(rgba->width) * static_cast<std::size_t>(rgba->height);
  a.stored.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    a.stored[i] =
        static_cast<float>(rgba->pixels[i * static_cast<std::size_t>(rgba->channels)]) / 255.0f;
  return a;
}

/** The region's <fileset> in <files> (the standard's place), else beside <files> under <MPCDI>
 * (where Christie's Mystique 2.3 writes them). */
const Element* fileset(const Element& root, const std::string& region) {
  for (const Element* parent : {root.child("files"), &root}) {
    if (parent == nullptr) continue;
    for (const Element* f : parent->all("fileset"))
      if (const std::string* r = f->attribute("region"); r != nullptr && *r == region) return f;
  }
  return nullptr;
}

} // namespace

std::expected<std::vector<planet::Channel>, std::string>
readMpcdi(const std::filesystem::path& file) {
  const std::string path = file.string();
  auto archive = detail::Archive::open(file);
  if (!archive) return std::unexpected(archive.error());
  const auto xml = archive->read("mpcdi.xml", std::size_t{64} << 20);
  if (!xml) return fail(path, xml.error());
  auto root = detail::parseXml(*xml, path + ": mpcdi.xml");
  if (!root) return std::unexpected(root.error());
  const std::string doc = path + ": mpcdi.xml";
  if ((*root)->name != "MPCDI") return fail(doc, "the root element is not <MPCDI>");
  const std::string* profileName = (*root)->attribute("profile");
  detail::Profile profile;
  if (profileName == nullptr) return fail(doc, "<MPCDI> has no profile");
  if (*profileName == "2d")
    profile = detail::Profile::Media2d;
  else if (*profileName == "3d")
    profile = detail::Profile::Simulation3d;
  else
    return fail(doc,
                "profile \"" + *profileName +
                    "\" is not read: tellus reads \"2d\" (2D media) and \"3d\" (3D "
                    "simulation), not \"a3\" (advanced 3D) or \"sl\" (shader lamp)");
  const Element* display = (*root)->child("display");
  if (display == nullptr) return fail(doc, "no <display>");
  std::vector<planet::Channel> channels;
  std::set<std::string> ids, names;
  for (const Element* buffer : display->all("buffer"))
    for (const Element* region : buffer->all("region")) {
      const std::string* id = region->attribute("id");
      if (id == nullptr || id->empty())
        return fail(doc, "region " + std::to_string(channels.size()) + " has no id");
      const std::string where = doc + ": region \"" + *id + "\"";
      if (!ids.insert(*id).second) return fail(where, "repeated");
      detail::RegionInput in;
      in.id = *id;
      const auto w = resolution(*region, "xResolution");
      if (!w) return fail(where, w.error());
      const auto h = resolution(*region, "yResolution");
      if (!h) return fail(where, h.error());
      in.width = *w;
      in.height = *h;
      if (const Element* f = region->child("frustum")) {
        auto frustum = readFrustum(*f);
        if (!frustum) return fail(where, frustum.error());
        in.frustum = *frustum;
      }
      if (const Element* f = region->child("coordinateFrame")) {
        auto frame = readFrame(*f);
        if (!frame) return fail(where, frame.error());
        in.frame = *frame;
      }
      const Element* set = fileset(**root, *id);
      if (set == nullptr) return fail(where, "no <fileset region=\"" + *id + "\"> in <files>");
      const Element* warp = set->child("geometryWarpFile");
      const Element* warpPath = warp != nullptr ? warp->child("path") : nullptr;
      if (warpPath == nullptr || warpPath->text.empty())
        return fail(where, "no geometryWarpFile with a <path>");
      const auto pfmBytes = archive->read(warpPath->text);
      if (!pfmBytes) return fail(where, "geometryWarpFile: " + pfmBytes.error());
      auto pfm = parsePfm(*pfmBytes, where + ": " + warpPath->text);
      if (!pfm) return std::unexpected(pfm.error());
      in.warp = std::move(*pfm);
      if (const Element* alpha = set->child("alphaMap")) {
        const Element* p = alpha->child("path");
        if (p == nullptr || p->text.empty()) return fail(where, "alphaMap: no <path>");
        double gamma = 2.2;
        if (const Element* g = alpha->child("gammaEmbedded")) {
          const auto v = number(g->text, "alphaMap: gammaEmbedded");
          if (!v || *v <= 0.0 || *v > 10.0)
            return fail(where, "alphaMap: gammaEmbedded must be a number in (0, 10]");
          gamma = *v;
        }
        const auto png = archive->read(p->text, std::size_t{256} << 20);
        if (!png) return fail(where, "alphaMap: " + png.error());
        auto a = readAlpha(*png, gamma);
        if (!a) return fail(where, "alphaMap " + p->text + ": " + a.error());
        in.alpha = std::move(*a);
      }
      auto channel = detail::makeChannel(profile, in, where);
      if (!channel) return std::unexpected(channel.error());
      if (!names.insert(channel->name).second)
        return fail(where, "its channel name \"" + channel->name + "\" is another region's too");
      channels.push_back(std::move(*channel));
    }
  if (channels.empty()) return fail(doc, "no <region> in <display><buffer>");
  return channels;
}

} // namespace tellus::mpcdi
