// The master's console over HTTP/JSON on loopback (ClusterControl.hpp).

#include "ClusterControl.hpp"

#include <tellus/proxy/HttpServer.hpp>

#include <charconv>

namespace tellus::commands {
namespace {

HttpResponse json(int status, std::string_view body) {
  return HttpResponse::text(status, "application/json", body);
}

} // namespace

std::expected<std::unique_ptr<Console>, std::string> Console::start(const std::string& hostPort) {
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
