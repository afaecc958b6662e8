#include "GeodesyTriaxial.hpp"

#include <tellus/planet/Geodesy.hpp>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Math.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace tellus {

struct Geodesy::Impl {
  planet::Body body;
  GeographicLib::Geocentric geocentric; ///< biaxial bodies (a, f = 1 - c/a)
  bool triaxial = false;
};

Geodesy::Geodesy(EarthModel model)
    : Geodesy(model == EarthModel::Wgs84 ? planet::earthBody() : planet::earthSphereBody()) {}

Geodesy::Geodesy(const planet::Body& body) {
  const std::string err = body.validate();
  if (!err.empty()) throw std::invalid_argument(err);
  // WGS84 keeps its defining flattening (1 - c/a rounds differently by an ulp). A triaxial body
  // does not use the Geocentric object; it gets a valid (a, c) shape.
  const planet::Body wgs84 = planet::earthBody();
  const double f = body.radiusA == wgs84.radiusA && body.radiusC == wgs84.radiusC
                       ? 1.0 / 298.257223563
                       : 1.0 - body.radiusC / body.radiusA;
  impl_ = std::make_unique<Impl>(
      Impl{body, GeographicLib::Geocentric(body.radiusA, f), body.isTriaxial()});
}

Geodesy::~Geodesy() = default;
Geodesy::Geodesy(Geodesy&&) noexcept = default;
Geodesy& Geodesy::operator=(Geodesy&&) noexcept = default;

EarthModel Geodesy::model() const noexcept {
  return impl_->body.isSphere() ? EarthModel::Sphere : EarthModel::Wgs84;
}
const planet::Body& Geodesy::body() const noexcept {
  return impl_->body;
}
double Geodesy::equatorialRadius() const noexcept {
  return impl_->body.radiusA;
}
double Geodesy::minEquatorialRadius() const noexcept {
  return impl_->body.radiusB;
}
double Geodesy::polarRadius() const noexcept {
  return impl_->body.radiusC;
}

Ecef Geodesy::toEcef(double latDeg, double lonDeg, double heightM) const noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg) || !std::isfinite(heightM))
    return {nan, nan, nan};
  if (impl_->triaxial) {
    const planet::Body& b = impl_->body;
    return planet::triaxialToEcef(b.radiusA, b.radiusB, b.radiusC, latDeg, lonDeg, heightM);
  }
  Ecef p;
  impl_->geocentric.Forward(latDeg, lonDeg, heightM, p.x, p.y, p.z);
  return p;
}

Geodetic Geodesy::fromEcef(const Ecef& p) const noexcept {
  if (impl_->triaxial) {
    const planet::Body& b = impl_->body;
    return planet::triaxialFromEcef(b.radiusA, b.radiusB, b.radiusC, p);
  }
  Geodetic g;
  impl_->geocentric.Reverse(p.x, p.y, p.z, g.latDeg, g.lonDeg, g.heightM);
  return g;
}

Ecef Geodesy::surfaceNormal(double latDeg, double lonDeg) const noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(std::abs(latDeg) <= 90.0) || !std::isfinite(lonDeg)) return {nan, nan, nan};
  // Latitude and longitude are those of the normal on every body (planetographic), so the
  // normal does not depend on the shape.
  double sphi = 0, cphi = 0, slam = 0, clam = 0;
  GeographicLib::Math::sincosd(latDeg, sphi, cphi);
  GeographicLib::Math::sincosd(lonDeg, slam, clam);
  return Ecef{cphi * clam, cphi * slam, sphi};
}

} // namespace tellus
