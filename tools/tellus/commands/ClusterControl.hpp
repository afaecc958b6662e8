#pragma once
/**
 * @file ClusterControl.hpp
 * @brief The master's console over HTTP/JSON on loopback (`tellus cluster --control HOST:PORT`,
 * docs/design/cluster.md "The console"): the proxy's HTTP server (POST accepted) answers
 * GET /status from the snapshot the master publishes each frame and queues the commands
 * (cluster::parseControl) for the master's next frame. A path file to play is read here, so that
 * a bad one is refused with its error.
 */

#include <tellus/cluster/Control.hpp>
#include <tellus/planet/FlightPath.hpp>

#include <cstdint>
#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace tellus {
class HttpServer;
}

namespace tellus::commands {

struct ConsoleCommand {
  cluster::ControlRequest request;
  std::optional<planet::FlightPath> flight; ///< PathCommand Play with a file: the file read
  int layer = -1; ///< LayerCommand: the layer's index (0 the base, then the overlays)
  int time = -1;  ///< LayerCommand with a time: its index in the layer's TIME values
};

/** A layer the console may set: its name and TIME values. */
struct ConsoleLayer {
  std::string name;
  std::vector<std::string> times;
};

class Console {
public:
  /** Listens on HOST:PORT (loopback only; PORT 0: any free one). POST /layer names one of
   * `layers` (those a frame's state carries; opacity and visibility for overlays only), its
   * time one of the layer's: else a 400 saying so. */
  static std::expected<std::unique_ptr<Console>, std::string>
  start(const std::string& hostPort, std::vector<ConsoleLayer> layers);
  ~Console();
  std::uint16_t port() const;
  /** The commands queued since the last call, in order. */
  std::vector<ConsoleCommand> take();
  /** GET /status's body from now on. */
  void publish(std::string status);

private:
  Console() = default;
  std::unique_ptr<HttpServer> server_;
  std::mutex mutex_;
  std::vector<ConsoleCommand> queue_;
  std::string status_ = "{}\n";
  std::vector<ConsoleLayer> layers_;
};

} // namespace tellus::commands
