#pragma once
// A tile service's front end served as `tellus serve` serves it: a ProxyFrontEnd behind a real
// HttpServer on a loopback port (bound to 0, read back), two threads. Declare it after the tile
// service it answers from: it stops the server before the service goes.
#include "HttpClient.hpp"

#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace tellus::test {

class ServedFrontEnd {
public:
  explicit ServedFrontEnd(TileService& tiles, FrontEndOptions options = {})
      : front_(std::make_unique<ProxyFrontEnd>(tiles, std::move(options))) {
    HttpServerOptions so;
    so.threads = 2;
    server_ = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front_->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server_->start());
  }
  ~ServedFrontEnd() { server_->stop(); }
  ServedFrontEnd(const ServedFrontEnd&) = delete;
  ServedFrontEnd& operator=(const ServedFrontEnd&) = delete;

  std::uint16_t port() const { return server_->port(); }
  HttpResult get(const std::string& target) const {
    return httpGet("http://127.0.0.1:" + std::to_string(port()) + target);
  }

private:
  std::unique_ptr<ProxyFrontEnd> front_;
  std::unique_ptr<HttpServer> server_;
};

} // namespace tellus::test
