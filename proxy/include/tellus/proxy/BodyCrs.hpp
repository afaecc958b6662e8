#pragma once
/**
 * @file BodyCrs.hpp
 * @brief The coordinate reference system a layer's body gives its WMS and WMTS (issue 26;
 * docs/design/bodies-proxy.md).
 *
 * A layer on the Earth keeps EPSG:4326, CRS:84 and EPSG:3857. A layer on another body is
 * geographic on that body: the IAU planetary codes (NAIF id x 100; 00 = the body's sphere or
 * ellipsoid, planetocentric latitude), written `IAU:30100` in WMS 1.3.0 (GeoServer's IAU
 * authority), `IAU2000:30100` in WMS 1.1.1 (the USGS Astrogeology / MapServer spelling) and
 * `urn:ogc:def:crs:IAU:2015:30100` in WMTS (the OGC registry's IAU authority). The IAU 2015
 * definitions put latitude first (as EPSG:4326), so a WMS 1.3.0 BBOX in them is lat/lon and 1.1.1
 * stays lon/lat.
 */

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

/** A body's geographic CRS and the sphere its WMTS scale denominators are counted on. */
struct BodyCrs {
  std::string_view body;    ///< lower case, e.g. "moon"
  std::int32_t iauCode = 0; ///< e.g. 30100
  double meanRadiusM = 0.0; ///< metres, for WMTS scale denominators
};

/** The built-in table (the IAU 2015 report's bodies that planetarium shows visit); std::nullopt
 * for the Earth and for a body the table does not know (its layers are left out of WMS and WMTS:
 * there is no CRS to name them by). Case-insensitive. */
std::optional<BodyCrs> bodyCrs(std::string_view body);

/** The IAU code a WMS CRS/SRS value names: `IAU:n`, `IAU2000:n`, `IAU_2015:n`, `IAU:2015:n`
 * (any case, as the GeoServer, MapServer, PROJ and OGC-URN spellings have it). std::nullopt for
 * anything else. */
std::optional<std::int32_t> parseIauCrs(std::string_view crs);

/** The canonical WMS spellings of a code: "IAU:30100" (1.3.0), "IAU2000:30100" (1.1.1). */
std::string iauCrs130(std::int32_t code);
std::string iauCrs111(std::int32_t code);
/** The WMTS SupportedCRS of a code: "urn:ogc:def:crs:IAU:2015:30100". */
std::string iauCrsUrn(std::int32_t code);

} // namespace tellus
