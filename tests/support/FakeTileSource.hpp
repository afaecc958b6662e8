#pragma once
// The one fake ITileSource (tellus/cache/TileSource.hpp) of the tests: layers with their grids and
// what each tile answers, delivered at once, on the fake's own thread, or when the test says so;
// every request recorded. No network, no sleep: a test that wants a tile late holds it and answers
// it after the event it waits for.
//
//   test::FakeTileSource src({"ramp", grid, "image/png", rampTiles(grid)}); // every name: "ramp"
//   src.addLayer({"heights", heightGrid, "application/bil16", FakeTileSource::bytes(b, type)});
//   src.setDelivery(FakeTileSource::Delivery::Held);  // the test answers: answer(), release()
//   src.failRequest(3);                               // the third request fails, whatever it asks
//
// Thread safety: every method may be called from any thread. Answers (the layers' functions) run
// outside the fake's lock, one at a time; callbacks run outside every lock.

#include <tellus/cache/TileSource.hpp>

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace tellus::test {

class FakeTileSource final : public ITileSource {
public:
  /// What a tile of a layer is: computed when the request is answered (not when it is made).
  using Answer = std::function<TileResult(const TileAddress&)>;

  struct Layer {
    std::string name; ///< what describe() calls the dataset
    GridSpec grid;    ///< the lat/long grid
    std::string mimeType = "image/png";
    Answer answer; ///< empty: the fallback answer (every tile absent unless set)
  };

  enum class Delivery {
    Immediate, ///< inside request(), on the caller's thread (the default)
    Worker,    ///< on the fake's own thread, in request order, as soon as it gets to them
    Held,      ///< when the test says: answer(), release()
  };

  /** A request as made, and whether it is still open (neither answered nor cancelled). */
  struct Request {
    TileRequestId id = 0; ///< 1 for the first request, then 2, 3, ...
    TileAddress address;
    double priority = 0.0; ///< as made (reprioritize() only counts)
    bool open = true;
  };

  /** No layers: describe() knows none; tiles of unknown layers are absent. */
  FakeTileSource() = default;
  /** Every layer name is this layer (describe() gives its name whatever was asked). */
  explicit FakeTileSource(Layer forEveryName);
  /** Stops the worker; requests still open are dropped without being answered. */
  ~FakeTileSource() override;
  FakeTileSource(const FakeTileSource&) = delete;
  FakeTileSource& operator=(const FakeTileSource&) = delete;

  // ---- configuration (before or between requests)

  /** A layer by its name (replaces one of the same name). */
  void addLayer(Layer layer);
  /** How tiles of layers without an answer of their own are answered (default: absent). */
  void setFallbackAnswer(Answer answer);
  void setDelivery(Delivery delivery);
  /** Requests for which this is true are held whatever the delivery (e.g. one time of a layer). */
  void holdIf(std::function<bool(const TileAddress&)> held);
  /** The n-th request (its id) fails with this message instead of its layer's answer. */
  void failRequest(TileRequestId n, std::string message = "fake failure");

  // ---- answers

  static TileResult
  result(TileStatus status, std::vector<std::byte> bytes = {}, std::string contentType = {});
  static Answer absent();
  static Answer failed(std::string message = "fake failure");
  /** Every tile these bytes (status Ok). */
  static Answer bytes(std::vector<std::byte> bytes, std::string contentType);

  /** Answers an open request with its layer's answer; false when it is not open. */
  bool answer(TileRequestId id);
  /** Answers an open request with this result; false when it is not open. */
  bool answer(TileRequestId id, TileResult result);
  /** Answers the oldest open request for this key (any layer) with this result. */
  bool answer(const TileKey& key, TileResult result);
  /** Answers up to n held requests, oldest first, with their layers' answers; how many. */
  std::size_t release(std::size_t n = static_cast<std::size_t>(-1));

  // ---- what was asked

  /** Every request since the fake was made (or since forgetRequests()), in order. */
  std::vector<Request> requests() const;
  std::vector<Request> openRequests() const;
  std::size_t requestCount() const;
  std::size_t openCount() const;
  /** Requests for a layer at a time ("" = the default time). */
  std::size_t requestsFor(std::string_view layer, std::string_view time = {}) const;
  /** The deepest level asked of a layer, or -1. */
  int deepestLevel(std::string_view layer) const;
  /** The requests cancelled (cancel() returned true), in order. */
  std::vector<TileRequestId> cancelled() const;
  std::size_t reprioritizations() const;
  /** requests() and requestsFor() start again from here; open requests stay answerable. */
  void forgetRequests();

  // ---- ITileSource

  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;

private:
  struct Entry {
    Request request;
    Callback done;
    bool held = false;
  };

  /** The answer to a request (its layer's, a failure asked for, or the fallback). */
  TileResult compute(const TileAddress& address, TileRequestId id);
  /** Takes an open request's callback and closes it; empty when it was not open. */
  Callback take(TileRequestId id);
  void workLoop();

  mutable std::mutex mutex_;
  std::mutex answerMutex_; ///< answers run one at a time (they may keep caches)
  std::condition_variable workCv_;
  std::map<std::string, Layer, std::less<>> layers_;
  std::optional<Layer> forEveryName_;
  Answer fallback_;
  Delivery delivery_ = Delivery::Immediate;
  std::function<bool(const TileAddress&)> holdIf_;
  std::map<TileRequestId, std::string> failing_;
  std::vector<Entry> entries_; ///< by id - 1
  std::size_t firstRecorded_ = 0;
  std::vector<TileRequestId> cancelled_;
  std::size_t reprioritizations_ = 0;
  std::deque<TileRequestId> workQueue_;
  bool stopping_ = false;
  std::thread worker_;
};

} // namespace tellus::test
