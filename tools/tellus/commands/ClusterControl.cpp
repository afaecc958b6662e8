// The master's console over HTTP/JSON on loopback (ClusterControl.hpp).

#include "ClusterControl.hpp"

#include <tellus/cluster/FrameState.hpp>
#include <tellus/proxy/HttpServer.hpp>

#include <algorithm>
#include <charconv>

namespace tellus::commands {
namespace {

HttpResponse json(int status, std::string_view body) {
  return HttpResponse::text(status, "application/json", body);
}

/** The layer command checked against the layers: their indexes, else why not. */
std::expected<std::pair<int, int>, std::string>
resolveLayer(const cluster::LayerCommand& l, const std::vector<ConsoleLayer>& layers) {
  for (std::size_t i = 0; i < layers.size(); ++i) {
    if (layers[i].name != l.layer) continue;
    if (i >= static_cast<std::size_t>(cluster::kFrameLayers))
      return std::unexpected(l.layer + ": a frame carries the first " +
                             std::to_string(cluster::kFrameLayers) + " layers only");
    if (i == 0 && (l.opacity || l.visible))
      return std::unexpected(l.layer + " is the base layer: only its time can be set");
    int time = -1;
    if (l.time) {
      const auto& t = layers[i].times;
      const auto it = std::find(t.begin(), t.end(), *l.time);
      if (it == t.end())
        return std::unexpected(l.layer + " has no time " + *l.time +
                               (t.empty() ? std::string(" (it has no times)")
                                          : " (" + t.front() + " ... " + t.back() + ")"));
      time = static_cast<int>(it - t.begin());
    }
    return std::pair{static_cast<int>(i), time};
  }
  std::string names;
  for (const ConsoleLayer& x : layers)
    names += (names.empty() ? "" : ", ") + x.name;
  return std::unexpected("no drawn layer " + l.layer + " (drawn: " + names + ")");
}

} // namespace

std::expected<std::unique_ptr<Console>, std::string>
Console::start(const std::string& hostPort, std::vector<ConsoleLayer> layers) {
  const auto colon = hostPort.rfind(':');
  if (colon == std::string::npos)
    return std::unexpected("--control must be HOST:PORT: " + hostPort);
  std::string host = hostPort.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  if (host != "127.0.0.1" && host != "localhost" && host != "::1")
    return std::unexpected("--control listens on loopback only (127.0.0.1, ::1): " + hostPort);
  unsigned port = 0;
  const std::string digits = hostPort.substr(colon + 1);
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), port);
  if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size() || port > 65535)
    return std::unexpected("--control's port must be 0-65535: " + hostPort);
  std::unique_ptr<Console> console(new Console());
  console->layers_ = std::move(layers);
  HttpServerOptions o;
  o.host = host == "localhost" ? "127.0.0.1" : host;
  o.port = static_cast<std::uint16_t>(port);
  o.threads = 1;
  o.acceptPost = true;
  o.serverName = "tellus-cluster";
  Console* self = console.get();
  console->server_ = std::make_unique<HttpServer>(o, [self](HttpRequest&& req, Responder respond) {
    if (req.refusal != HttpRefusal::None)
      return respond(json(req.refusal == HttpRefusal::MethodNotAllowed ? 405 : 400,
                          cluster::errorJson(toString(req.refusal))));
    auto parsed = cluster::parseControl(req.method, req.path, req.body);
    if (!parsed)
      return respond(json(parsed.error().status, cluster::errorJson(parsed.error().message)));
    if (std::holds_alternative<cluster::StatusQuery>(*parsed)) {
      std::lock_guard lock(self->mutex_);
      return respond(json(200, self->status_));
    }
    ConsoleCommand c{std::move(*parsed), std::nullopt};
    if (const auto* l = std::get_if<cluster::LayerCommand>(&c.request)) {
      const auto at = resolveLayer(*l, self->layers_);
      if (!at) return respond(json(400, cluster::errorJson(at.error())));
      c.layer = at->first;
      c.time = at->second;
    }
    if (const auto* p = std::get_if<cluster::PathCommand>(&c.request); p && !p->file.empty()) {
      auto flight = planet::FlightPath::read(p->file);
      if (!flight) return respond(json(400, cluster::errorJson(flight.error())));
      for (const planet::Keyframe& k : flight->keyframes())
        if (!k.layerTimes.empty() || !k.body.empty())
          return respond(
              json(400,
                   cluster::errorJson(p->file +
                                      ": a keyframe's \"times\" and \"body\" are not sent to "
                                      "channels (the layer times of --path's keyframes are)")));
      c.flight = std::move(*flight);
    }
    {
      std::lock_guard lock(self->mutex_);
      self->queue_.push_back(std::move(c));
    }
    respond(json(202, "{\"queued\": true}\n")); // applied at the master's next frame
  });
  if (auto started = console->server_->start(); !started)
    return std::unexpected("--control " + hostPort + ": " + started.error());
  return console;
}

Console::~Console() {
  if (server_) server_->stop();
}

std::uint16_t Console::port() const {
  return server_->port();
}

std::vector<ConsoleCommand> Console::take() {
  std::lock_guard lock(mutex_);
  std::vector<ConsoleCommand> out;
  out.swap(queue_);
  return out;
}

void Console::publish(std::string status) {
  std::lock_guard lock(mutex_);
  status_ = std::move(status);
}

} // namespace tellus::commands
