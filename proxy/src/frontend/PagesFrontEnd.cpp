// The page at `/` and its files, `/layers.json`, the plain-text index (`/index.txt`, and `/` when
// the page is not built in) and `/metrics` (Prometheus text format).
#include "frontend/FrontEnd.hpp"

#include <tellus/proxy/WebPage.hpp>

namespace tellus {

void PagesFrontEnd::index(const HttpRequest& req, const Responder& respond) const {
  if (req.path == "/layers.json") {
    auto r =
        layersJsonResponse(req, fe_.options.title, fe_.tiles.layers(), [&](const LayerSpec& l) {
          return fe_.tiles.wholePolarRows(l.name);
        });
    fe_.common(r);
    return respond(std::move(r));
  }
  if (auto r = webAssetResponse(req)) {
    fe_.common(*r);
    return respond(std::move(*r));
  }
  const std::string base = fe_.baseUrl(req);
  std::string t = fe_.options.title + "\n\n";
  t += "WMS:        " + base + "/wms?SERVICE=WMS&REQUEST=GetCapabilities\n";
  t += "World Wind: " + base + "/wwtile?T=<layer>&L=<level>&X=<column>&Y=<row>\n";
  t += "Static:     " + base + "/tiles/<layer>/<level>/<row>/<row>_<column>.<ext>\n";
  if (webPageEmbedded()) t += "Map page:   " + base + "/  (layers: " + base + "/layers.json)\n";
  t += "\nlayers:\n";
  for (const auto& l : fe_.tiles.layers()) {
    t += "  " + l.name + "  " + l.dataset.mimeType + "  " +
         std::to_string(l.dataset.grid.levelZeroDeltaDeg) + " deg level 0, " +
         std::to_string(l.dataset.grid.numLevels) + " levels  e.g. " + base +
         "/wwtile?T=" + l.name + "&L=0&X=0&Y=0\n";
  }
  respond(fe_.plain(200, t));
}

void PagesFrontEnd::metrics(const Responder& respond) const {
  const FetchBudget& budget = fe_.budget;
  auto r = HttpResponse::text(
      200,
      "text/plain; version=0.0.4; charset=utf-8",
      fe_.metrics.render(fe_.tiles.upstreamMetrics(),
                         fe_.tiles.cachedBytes(),
                         fe_.composer.decodedCacheBytes(),
                         FetchBudgetMetrics{budget.perMinute(), budget.refused(), budget.clients()},
                         fe_.tiles.cacheHealth()));
  r.setHeader("Cache-Control", "no-store");
  respond(std::move(r));
}

} // namespace tellus
