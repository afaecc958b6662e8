#pragma once
// Validation of WMS (and WMTS) documents against the official schemas and DTDs vendored in
// tests/data/schemas (see PROVENANCE there): xmllint from libxml2-utils, offline (--nonet), the
// schema URLs resolved through tests/data/schemas/catalog.xml.

#include "TempDir.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <sys/wait.h>

namespace tellus::test {

enum class WmsDocument {
  Capabilities111, ///< WMT_MS_Capabilities, DOCTYPE WMS_MS_Capabilities.dtd (--valid)
  Exception111,    ///< ServiceExceptionReport, DOCTYPE WMS_exception_1_1_1.dtd (--valid)
  Capabilities130, ///< WMS_Capabilities against capabilities_1_3_0.xsd and SLD 1.1.0's extension
  Exception130,    ///< ServiceExceptionReport against exceptions_1_3_0.xsd
  WmtsCapabilities100, ///< WMTS 1.0.0 Capabilities against wmtsGetCapabilities_response.xsd
  OwsException110,     ///< OWS 1.1 ExceptionReport (WMTS) against owsExceptionReport.xsd
};

struct SchemaVerdict {
  bool valid = false;
  std::string output; ///< xmllint's messages (or why it could not run)
};

inline std::filesystem::path wmsSchemaDir() {
  return std::filesystem::path(TELLUS_TEST_SOURCE_DIR) / "data" / "schemas";
}

/**
 * @brief xmllint's verdict on `xml` as a document of the given kind.
 *
 * 1.1.1 documents are validated against the DTD their own DOCTYPE names (--valid, the URL mapped
 * by the catalog), so a document that names another DTD, or none, fails too; 1.3.0 documents
 * against the vendored XSDs (capabilities_1_3_0.xsd, through SLD 1.1.0's sld_capabilities.xsd
 * that imports it). Never valid when xmllint is missing (it is a test dependency:
 * tools/debian-packages.txt).
 */
inline SchemaVerdict validateWms(std::string_view xml, WmsDocument kind) {
  SchemaVerdict v;
  if (std::system("command -v xmllint >/dev/null 2>&1") != 0) {
    v.output = "xmllint is not installed (Debian: libxml2-utils)";
    return v;
  }
  const std::filesystem::path dir = wmsSchemaDir();
  TempDir tmp("xmllint");
  const auto file = tmp.path() / "doc.xml";
  std::ofstream(file, std::ios::binary).write(xml.data(), static_cast<std::streamsize>(xml.size()));
  std::string how;
  switch (kind) {
  case WmsDocument::Capabilities111:
  case WmsDocument::Exception111:
    how = "--valid";
    break;
  case WmsDocument::Capabilities130:
    // SLD 1.1.0's capabilities extension imports the WMS 1.3.0 schema: a document is checked
    // against both, so that sld:GetLegendGraphic (an _ExtendedOperation) is known.
    how = "--schema '" + (dir / "opengis/sld/1.1.0/sld_capabilities.xsd").string() + "'";
    break;
  case WmsDocument::Exception130:
    how = "--schema '" + (dir / "opengis/wms/1.3.0/exceptions_1_3_0.xsd").string() + "'";
    break;
  case WmsDocument::WmtsCapabilities100:
    how = "--schema '" + (dir / "opengis/wmts/1.0/wmtsGetCapabilities_response.xsd").string() + "'";
    break;
  case WmsDocument::OwsException110:
    how = "--schema '" + (dir / "opengis/ows/1.1.0/owsExceptionReport.xsd").string() + "'";
    break;
  }
  const std::string cmd = "XML_CATALOG_FILES='" + (dir / "catalog.xml").string() +
                          "' xmllint --nonet --noout " + how + " '" + file.string() + "' 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (pipe == nullptr) {
    v.output = "popen failed";
    return v;
  }
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0)
    v.output.append(buf, n);
  const int status = ::pclose(pipe);
  v.valid = status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  // xmllint --valid says nothing and exits 0 for a document without a DOCTYPE: not valid here.
  if ((kind == WmsDocument::Capabilities111 || kind == WmsDocument::Exception111) &&
      xml.find("<!DOCTYPE") == std::string_view::npos) {
    v.valid = false;
    v.output += "no DOCTYPE: a 1.1.1 document must name its DTD";
  }
  return v;
}

/**
 * @brief validateWms for a WMTS 1.0.0 Capabilities document, except for the one known erratum of
 * the official schema: it types MinTileRow, MaxTileRow, MinTileCol and MaxTileCol as
 * xs:positiveInteger although 07-057r7 (table 17 and its note) counts them from 0, so every
 * server's limits that include the first row or column are refused by it (GeoWebCache issues 250
 * and 411, MapProxy, MapCache alike). Those messages, and only those, are forgiven; the schema
 * stays as the OGC publishes it. `output` keeps every message.
 */
inline SchemaVerdict validateWmtsCapabilities(std::string_view xml) {
  SchemaVerdict v = validateWms(xml, WmsDocument::WmtsCapabilities100);
  if (v.valid) return v;
  bool onlyErratum = true, anyError = false;
  std::size_t start = 0;
  while (start < v.output.size()) {
    const std::size_t end = std::min(v.output.find('\n', start), v.output.size());
    const std::string_view line(v.output.data() + start, end - start);
    start = end + 1;
    if (line.find("validity error") == std::string_view::npos) continue;
    anyError = true;
    const bool limit = line.find("TileRow'") != std::string_view::npos ||
                       line.find("TileCol'") != std::string_view::npos;
    if (!limit || line.find("'0' is not a valid value of the atomic type 'xs:positiveInteger'") ==
                      std::string_view::npos)
      onlyErratum = false;
  }
  v.valid = anyError && onlyErratum;
  return v;
}

} // namespace tellus::test
