#include <tellus/planet/Geoid.hpp>

#include <GeographicLib/Geoid.hpp>

#include <cmath>
#include <exception>
#include <fstream>
#include <limits>
#include <sstream>

namespace tellus {

struct Geoid::Impl {
  Impl(const std::string& name, const std::string& dir, Interpolation i)
      : grid(name, dir, i == Interpolation::Cubic, /*threadsafe=*/true), interpolation(i) {}
  GeographicLib::Geoid grid;
  Interpolation interpolation;
  double spacingDeg = 0.0; ///< between the grid's nodes (360 / the PGM's width); 0: unknown
};

namespace {

/** The PGM's width (GeographicLib grids cover 360 degrees of longitude with width nodes, starting
 * at 0): "P5", comment lines, then "width height". 0 when the header cannot be read. */
int pgmWidth(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  if (!std::getline(in, line) || line.rfind("P5", 0) != 0) return 0;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') {
      std::istringstream words(line);
      int w = 0;
      return words >> w && w > 0 ? w : 0;
    }
  return 0;
}

} // namespace

std::expected<Geoid, std::string> Geoid::open(const std::filesystem::path& pgmFile,
                                              Interpolation interpolation) {
  // GeographicLib names a grid by directory and stem and appends ".pgm".
  if (pgmFile.extension() != ".pgm")
    return std::unexpected("geoid grid " + pgmFile.string() + ": not a .pgm file");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(pgmFile, ec))
    return std::unexpected("geoid grid " + pgmFile.string() + ": no such file");
  try {
    const std::filesystem::path dir = pgmFile.has_parent_path() ? pgmFile.parent_path() : ".";
    // threadsafe = true reads the whole grid into memory now: later calls are const and safe.
    auto impl = std::make_unique<Impl>(pgmFile.stem().string(), dir.string(), interpolation);
    if (const int w = pgmWidth(pgmFile); w > 0) impl->spacingDeg = 360.0 / w;
    return Geoid(std::move(impl));
  } catch (const std::exception& e) {
    return std::unexpected("geoid grid " + pgmFile.string() + ": " + e.what());
  }
}

Geoid::Geoid(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Geoid::~Geoid() = default;
Geoid::Geoid(Geoid&&) noexcept = default;
Geoid& Geoid::operator=(Geoid&&) noexcept = default;

double Geoid::undulationM(double latDeg, double lonDeg) const noexcept {
  // GeographicLib maps NaN to NaN but turns an infinite longitude into an index by floor(): refuse
  // every non-finite input here.
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg))
    return std::numeric_limits<double>::quiet_NaN();
  // Wrap to [-180, 180] exactly (remainder is exact), so huge longitudes index safely.
  const double lon = std::remainder(lonDeg, 360.0);
  try {
    return impl_->grid(latDeg, lon);
  } catch (...) { // the grid is in memory: nothing to read, nothing should throw
    return std::numeric_limits<double>::quiet_NaN();
  }
}

void Geoid::undulationsAlongParallel(double latDeg,
                                     double lon0Deg,
                                     double dLonDeg,
                                     std::span<double> out) const noexcept {
  const double step = impl_->spacingDeg;
  if (impl_->interpolation != Interpolation::Bilinear || !(step > 0.0) ||
      !(std::abs(latDeg) <= 90.0) || !std::isfinite(lon0Deg) || !std::isfinite(dLonDeg)) {
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = undulationM(latDeg, lon0Deg + static_cast<double>(i) * dLonDeg);
    return;
  }
  // Bilinear: at a fixed latitude N is linear in longitude between meridians k * step and
  // (k + 1) * step (the grid starts at longitude 0). N on those two meridians is looked up once per
  // cell the row enters.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double west = nan, east = nan, nWest = 0.0, nEast = 0.0, slope = 0.0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double lon = lon0Deg + static_cast<double>(i) * dLonDeg;
    if (!(lon >= west && lon < east)) { // entered another cell
      const double w = std::floor(lon / step) * step;
      // Going east into the next cell, its west meridian is the last one's east meridian.
      nWest = w == east ? nEast : undulationM(latDeg, w);
      west = w;
      east = w + step;
      nEast = undulationM(latDeg, east);
      slope = (nEast - nWest) / step;
    }
    out[i] = nWest + slope * (lon - west);
  }
}

double Geoid::ellipsoidHeightM(double latDeg, double lonDeg, double mslHeightM) const noexcept {
  return mslHeightM + undulationM(latDeg, lonDeg);
}

double Geoid::mslHeightM(double latDeg, double lonDeg, double ellipsoidHeightM) const noexcept {
  return ellipsoidHeightM - undulationM(latDeg, lonDeg);
}

Geoid::Interpolation Geoid::interpolation() const noexcept {
  return impl_->interpolation;
}

std::string Geoid::description() const {
  return impl_->grid.Description();
}

double Geoid::statedMaxErrorM() const noexcept {
  return impl_->grid.MaxError();
}

double
VerticalDatum::ellipsoidHeightM(double latDeg, double lonDeg, double mslHeightM) const noexcept {
  if (geoid_) return geoid_->ellipsoidHeightM(latDeg, lonDeg, mslHeightM);
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg))
    return std::numeric_limits<double>::quiet_NaN();
  return mslHeightM;
}

} // namespace tellus
