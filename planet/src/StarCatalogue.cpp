// The star catalogue's reader, placement, brightness and colour (StarCatalogue.hpp).
#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

namespace tellus::planet {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/** The fields of a line split at spaces and tabs. */
std::vector<std::string_view> fields(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t'))
      ++i;
    const std::size_t b = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t')
      ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

/** A whole field as a finite double, or nullopt. */
std::optional<double> number(std::string_view s) {
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

/** One data line as a star, or what is wrong with it. */
std::expected<Star, std::string> parseLine(std::string_view line) {
  const auto f = fields(line);
  if (f.size() != 5)
    return std::unexpected("expected 5 fields (HIP RA_deg Dec_deg Vmag B-V), got " +
                           std::to_string(f.size()));
  Star s;
  const auto r = std::from_chars(f[0].data(), f[0].data() + f[0].size(), s.hip);
  if (r.ec != std::errc{} || r.ptr != f[0].data() + f[0].size() || s.hip <= 0)
    return std::unexpected("the Hipparcos number '" + std::string(f[0]) +
                           "' is not a positive integer");
  const auto ra = number(f[1]), dec = number(f[2]), mag = number(f[3]);
  if (!ra || *ra < 0.0 || *ra >= 360.0)
    return std::unexpected("right ascension '" + std::string(f[1]) + "' is not in [0, 360) deg");
  if (!dec || *dec < -90.0 || *dec > 90.0)
    return std::unexpected("declination '" + std::string(f[2]) + "' is not in [-90, 90] deg");
  if (!mag || *mag < -2.0 || *mag > 25.0)
    return std::unexpected("V magnitude '" + std::string(f[3]) + "' is not in [-2, 25]");
  s.raRad = *ra * kDeg;
  s.decRad = *dec * kDeg;
  s.vmag = *mag;
  if (f[4] != "-") {
    const auto bv = number(f[4]);
    if (!bv || *bv < -1.0 || *bv > 4.0)
      return std::unexpected("B-V '" + std::string(f[4]) + "' is not '-' or in [-1, 4]");
    s.bv = *bv;
  }
  return s;
}

} // namespace

std::expected<StarCatalogue, std::string> StarCatalogue::parse(std::string_view text,
                                                               std::string_view name) {
  std::vector<Star> stars;
  std::size_t lineNo = 0, pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (fields(line).empty() || line.find_first_not_of(" \t") == line.find('#')) continue;
    auto star = parseLine(line);
    if (!star)
      return std::unexpected(std::string(name) + ":" + std::to_string(lineNo) + ": " +
                             star.error());
    stars.push_back(*star);
  }
  if (stars.empty()) return std::unexpected(std::string(name) + ": no stars");
  return StarCatalogue(std::move(stars));
}

std::expected<StarCatalogue, std::string> StarCatalogue::open(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected("star catalogue " + file.string() + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return std::unexpected("star catalogue " + file.string() + ": read error");
  return parse(text.str(), "star catalogue " + file.string());
}

const Star* StarCatalogue::find(std::int32_t hip) const noexcept {
  const auto it =
      std::find_if(stars_.begin(), stars_.end(), [&](const Star& s) { return s.hip == hip; });
  return it == stars_.end() ? nullptr : &*it;
}

glm::dvec3 starCelestialDirection(const Star& star) noexcept {
  return astro::equatorialDirection(star.raRad, star.decRad);
}

glm::dvec3 starDirectionEcef(const Star& star, double unixSeconds) noexcept {
  return astro::celestialToEcef(unixSeconds) * starCelestialDirection(star);
}

double starEnergy(double vmag, double brightness) noexcept {
  if (!(brightness > 0.0) || !std::isfinite(vmag)) return 0.0;
  const double e = brightness * kStarEnergyMag0 * std::pow(10.0, -0.4 * vmag / kStarDisplayGamma);
  return std::min(e, kStarEnergyCap);
}

double starTemperatureK(double bv) noexcept {
  // Ballesteros (2012), eq. 14: a black body through the Johnson B and V filters.
  return 4600.0 * (1.0 / (0.92 * bv + 1.7) + 1.0 / (0.92 * bv + 0.62));
}

std::array<double, 3> starColour(std::optional<double> bv) noexcept {
  if (!bv || !std::isfinite(*bv)) return {1.0, 1.0, 1.0};
  const double t = std::clamp(starTemperatureK(std::clamp(*bv, -0.4, 2.0)), 1667.0, 25000.0);
  // The Planckian locus in CIE 1931 xy (Kim et al. 2002, cubic splines in 1/T and x).
  const double t1 = 1e3 / t, t2 = t1 * t1, t3 = t2 * t1;
  const double x = t <= 4000.0 ? -0.2661239 * t3 - 0.2343589 * t2 + 0.8776956 * t1 + 0.179910
                               : -3.0258469 * t3 + 2.1070379 * t2 + 0.2226347 * t1 + 0.240390;
  const double x2 = x * x, x3 = x2 * x;
  const double y = t <= 2222.0   ? -1.1063814 * x3 - 1.34811020 * x2 + 2.18555832 * x - 0.20219683
                   : t <= 4000.0 ? -0.9549476 * x3 - 1.37418593 * x2 + 2.09137015 * x - 0.16748867
                                 : 3.0817580 * x3 - 5.87338670 * x2 + 3.75112997 * x - 0.37001483;
  // xyY (Y = 1) -> XYZ -> linear sRGB (IEC 61966-2-1), negatives (out of gamut) clipped.
  const double cx = x / y, cy = 1.0, cz = (1.0 - x - y) / y;
  std::array<double, 3> rgb{3.2406 * cx - 1.5372 * cy - 0.4986 * cz,
                            -0.9689 * cx + 1.8758 * cy + 0.0415 * cz,
                            0.0557 * cx - 0.2040 * cy + 1.0570 * cz};
  double top = 0.0;
  for (double& c : rgb) {
    c = std::max(c, 0.0);
    top = std::max(top, c);
  }
  // Scaled to a largest channel of 1, then encoded for the display (the sRGB transfer curve): the
  // framebuffer's values are shown as sRGB, as the imagery's are.
  for (double& c : rgb) {
    c /= top;
    c = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  }
  return rgb;
}

} // namespace tellus::planet
