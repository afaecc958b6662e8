#include <tellus/planet/Geoid.hpp>

#include <GeographicLib/Geoid.hpp>

#include <cmath>
#include <exception>
#include <limits>

namespace tellus {

struct Geoid::Impl {
  Impl(const std::string& name, const std::string& dir, Interpolation i)
      : grid(name, dir, i == Interpolation::Cubic, /*threadsafe=*/true), interpolation(i) {}
  GeographicLib::Geoid grid;
  Interpolation interpolation;
};

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
