#pragma once
/**
 * @file Capabilities.hpp
 * @brief The WMS 1.1.1 and 1.3.0 GetCapabilities documents, written from a protocol-neutral
 * model. Pure functions: the server fills the model from its configuration and sends the text
 * (1.1.1 as application/vnd.ogc.wms_xml, 1.3.0 as text/xml).
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/Wms.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** A style with its legend (LegendURL: a GetLegendGraphic URL, width x height pixels). */
struct CapabilitiesStyle {
  std::string name;
  std::string title;
  std::string legendUrl; ///< omitted when empty
  std::int32_t legendWidth = 0;
  std::int32_t legendHeight = 0;

  friend bool operator==(const CapabilitiesStyle&, const CapabilitiesStyle&) = default;
};

/** One named layer. */
struct CapabilitiesLayer {
  std::string name;
  std::string title;
  std::string abstract;            ///< omitted when empty
  Sector bbox{};                   ///< lon/lat (west, south, east, north)
  std::vector<std::string> styles; ///< style names; none means only the default style
  /** Styles with a title and a legend (value layers' colour maps), written after `styles`. */
  std::vector<CapabilitiesStyle> legendStyles;
  bool queryable = false; ///< queryable="1": GetFeatureInfo answers for it
  /** TIME dimension: explicit values and/or a period "start/end/resolution", written comma-joined
   * (values first). No Dimension is written when both are empty. */
  std::vector<std::string> timeValues;
  std::string timePeriod;
  std::string timeDefault; ///< the default attribute, omitted when empty
  bool opaque = true;
  /** Written as the layer keyword "LastUpdate=<Unix ms>", which World Wind Java reads to expire its
   * own tile cache (WMSCapabilities.getLayerLatestLastUpdateTime); omitted when 0. */
  std::int64_t lastUpdateMillis = 0;
  /** The layer's body (BodyCrs.hpp): 0 for the Earth (EPSG:4326, CRS:84 and EPSG:3857), else the
   * body's geographic IAU code, its only CRS (IAU:n in 1.3.0, IAU2000:n in 1.1.1). */
  std::int32_t iauCode = 0;

  friend bool operator==(const CapabilitiesLayer&, const CapabilitiesLayer&) = default;
};

/** The whole service. */
struct CapabilitiesModel {
  std::string title;
  std::string abstract;       ///< omitted when empty
  std::string onlineResource; ///< base URL as clients reach it, e.g. "http://host:port/wms?"
  std::vector<std::string> getMapFormats;
  /** GetFeatureInfo's INFO_FORMATs; the operation is declared only when there are some. */
  std::vector<std::string> getFeatureInfoFormats;
  /** GetLegendGraphic's FORMATs (the SLD profile's request); declared only when there are some:
   * in 1.1.1 as the DTD's <GetLegendGraphic> in Request, in 1.3.0 as <sld:GetLegendGraphic>, an
   * _ExtendedOperation of SLD 1.1.0 (sld_capabilities.xsd), with xmlns:sld and that schema in
   * xsi:schemaLocation. */
  std::vector<std::string> getLegendGraphicFormats;
  std::string updateSequence; ///< root updateSequence attribute, omitted when empty
  /** ISO 8601 UTC (e.g. 2026-11-23T00:00:00Z); written as the Service keyword
   * "LastUpdate=<value>", omitted when empty. */
  std::string lastUpdate;
  std::vector<CapabilitiesLayer> layers;
  std::int32_t maxWidth = 0;  ///< 1.3.0 MaxWidth, omitted when <= 0
  std::int32_t maxHeight = 0; ///< 1.3.0 MaxHeight, omitted when <= 0
};

/**
 * @brief The capabilities document of one version, UTF-8, one element per line.
 *
 * 1.1.1: WMT_MS_Capabilities with the WMS_MS_Capabilities.dtd DOCTYPE; SRS EPSG:4326 on the root
 * layer; LatLonBoundingBox and BoundingBox SRS="EPSG:4326" (lon/lat) per layer; time as Dimension
 * plus Extent. 1.3.0: WMS_Capabilities in the http://www.opengis.net/wms namespace; CRS
 * EPSG:4326 and CRS:84; EX_GeographicBoundingBox, BoundingBox CRS="CRS:84" (lon/lat) and
 * BoundingBox CRS="EPSG:4326" in EPSG axis order (minx = south latitude, miny = west longitude);
 * time as Dimension with the values as content. The root layer's box is the union of the layers'
 * (the globe when there are none). Numbers are printed shortest round-trip; text is XML-escaped.
 * When a layer lies on another body (iauCode), the CRSs move from the root layer (whose children
 * would inherit them) to each layer: an Earth layer lists the Earth's, a body's layer only its IAU
 * code with a BoundingBox in it (lat/lon in 1.3.0, as the IAU 2015 axes are); the root keeps
 * only its geographic box.
 */
std::string capabilitiesXml(WmsVersion version, const CapabilitiesModel& model);

/** The content type of a capabilities document: application/vnd.ogc.wms_xml (1.1.1) or text/xml
 * (1.3.0). */
std::string_view capabilitiesContentType(WmsVersion version) noexcept;

/** Shortest decimal text that reads back as the same double ("0.1", "-180", "1e-05"); -0 is "0".
 * Precondition: finite. */
std::string formatCoordinate(double value);

} // namespace tellus
