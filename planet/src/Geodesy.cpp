#include <tellus/planet/Geodesy.hpp>

#include <GeographicLib/Constants.hpp>
#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Math.hpp>

#include <cmath>
#include <limits>

namespace tellus {

namespace {
constexpr double kMeanEarthRadius = 6371008.8; // IUGG mean radius R1
}

struct Geodesy::Impl {
  EarthModel model;
  GeographicLib::Geocentric geocentric;
};

Geodesy::Geodesy(EarthModel model)
    : impl_(std::make_unique<Impl>(
          Impl{model,
               model == EarthModel::Wgs84
                   ? GeographicLib::Geocentric(GeographicLib::Constants::WGS84_a(),
                                               GeographicLib::Constants::WGS84_f())
                   : GeographicLib::Geocentric(kMeanEarthRadius, 0.0)})) {}

Geodesy::~Geodesy() = default;
Geodesy::Geodesy(Geodesy&&) noexcept = default;
Geodesy& Geodesy::operator=(Geodesy&&) noexcept = default;

EarthModel Geodesy::model() const noexcept {
  return impl_->model;
}
double Geodesy::equatorialRadius() const noexcept {
  return impl_->geocentric.EquatorialRadius();
}
double Geodesy::polarRadius() const noexcept {
  return impl_->geocentric.EquatorialRadius() * (1.0 - impl_->geocentric.Flattening());
}

Ecef Geodesy::toEcef(double latDeg, double lonDeg, double heightM) const noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg) || !std::isfinite(heightM))
    return {nan, nan, nan};
  Ecef p;
  impl_->geocentric.Forward(latDeg, lonDeg, heightM, p.x, p.y, p.z);
  return p;
}

Geodetic Geodesy::fromEcef(const Ecef& p) const noexcept {
  Geodetic g;
  impl_->geocentric.Reverse(p.x, p.y, p.z, g.latDeg, g.lonDeg, g.heightM);
  return g;
}

Ecef Geodesy::surfaceNormal(double latDeg, double lonDeg) const noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg)) return {nan, nan, nan};
  // The geodetic normal does not depend on the model's shape once latitude is geodetic.
  double sphi = 0, cphi = 0, slam = 0, clam = 0;
  GeographicLib::Math::sincosd(latDeg, sphi, cphi);
  GeographicLib::Math::sincosd(lonDeg, slam, clam);
  return Ecef{cphi * clam, cphi * slam, sphi};
}

} // namespace tellus
