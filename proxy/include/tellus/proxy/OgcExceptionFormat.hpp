#pragma once
/**
 * @file OgcExceptionFormat.hpp
 * @brief WMS service exception reports (the XML form; INIMAGE/BLANK images are the server's) and
 * the scrubbing of messages before they reach a client.
 */

#include <tellus/proxy/Wms.hpp>

#include <string>
#include <string_view>

namespace tellus {

/** Longest message (bytes, after sanitizing) written into an exception report. */
inline constexpr std::size_t kMaxClientMessageBytes = 1024;

/** What to send: status, Content-Type and body. Exceptions must never be cached (the server adds
 * Cache-Control: no-cache). */
struct FormattedResponse {
  int httpStatus = 200;
  std::string contentType;
  std::string body;

  friend bool operator==(const FormattedResponse&, const FormattedResponse&) = default;
};

/**
 * @brief The XML exception report of a version.
 *
 * 1.3.0: text/xml, `<ServiceExceptionReport version="1.3.0" xmlns="http://www.opengis.net/ogc">`
 * (valid against exceptions_1_3_0.xsd); 1.1.1: application/vnd.ogc.se_xml with the
 * WMS_exception_1_1_1.dtd DOCTYPE (valid against it: no locator attribute, which that DTD does not
 * declare). code and locator attributes are omitted when empty. The message goes through
 * sanitizeForClient, is cut to kMaxClientMessageBytes and XML-escaped; the locator is sanitized and
 * escaped too. Status 200 (what WMS clients and CITE expect) unless httpStatusCodes: then
 * wmsExceptionHttpStatus(code).
 */
FormattedResponse
formatWmsException(WmsVersion version, const OgcException& exception, bool httpStatusCodes);

/** The opt-in HTTP status of an exception code: 400 for client errors (Missing*, Invalid*,
 * LayerNotDefined, StyleNotDefined, LayerNotQueryable, dimension and update-sequence errors), 501
 * for OperationNotSupported, 500 for NoApplicableCode and anything unknown. */
int wmsExceptionHttpStatus(std::string_view code) noexcept;

/**
 * @brief Removes what must not leak to a client: URLs (`scheme://...`, and `user:password@host`
 * without a scheme, replaced by "[url]"), absolute file-system paths (`/...`, `~/...`, `C:\...`,
 * replaced by "[path]"), up to the next whitespace, quote or closing bracket (trailing sentence
 * punctuation is kept; a '/' inside a word, "image/png" or "1/2", is not a path), and the values of
 * credentials: `name=value` and `name: value` whose name says it is a secret (api_key, apikey,
 * X-Api-Key, token, access_token, password, secret, signature, sig, auth, session, ...) and the
 * credentials after `Bearer`, `Basic` and `Digest`, replaced by "[redacted]" up to the next `&`,
 * `,`, `;`, whitespace or quote. The one redaction of every error a client sees (the front end
 * applies it to all of them).
 */
std::string sanitizeForClient(std::string_view message);

} // namespace tellus
