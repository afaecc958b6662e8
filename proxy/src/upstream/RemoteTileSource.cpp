#include <tellus/cache/RequestQueue.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>

#include <nlohmann/json.hpp>

#include <cctype>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

namespace tellus {

// ------------------------------------------------------------------------------------ JSON
// /layers.json through nlohmann-json, without exceptions: a first pass with its SAX parser refuses
// what is not JSON (saying where) and nesting deeper than a tellus server writes before anything
// is built; then the document, and the members each layer needs.
namespace {

using Json = nlohmann::json;

constexpr int kMaxDepth = 32; ///< /layers.json is three deep

class JsonCheck final : public nlohmann::json_sax<Json> {
public:
  std::string error; ///< empty: the text is JSON nested at most kMaxDepth deep

  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool key(string_t&) override { return true; }
  bool start_object(std::size_t) override { return enter(); }
  bool end_object() override { return leave(); }
  bool start_array(std::size_t) override { return enter(); }
  bool end_array() override { return leave(); }
  bool parse_error(std::size_t position,
                   const std::string&,
                   const nlohmann::detail::exception& e) override {
    // "[json.exception.parse_error.101] parse error at line 1, column 5: why": only the why,
    // and the offset of the byte it stopped at.
    std::string why = e.what();
    if (const auto colon = why.find(": "); colon != std::string::npos) why.erase(0, colon + 2);
    error = "JSON: " + why + " at offset " + std::to_string(position > 0 ? position - 1 : 0);
    return false;
  }

private:
  bool enter() {
    if (++depth_ <= kMaxDepth) return true;
    error = "JSON: nested more than " + std::to_string(kMaxDepth) + " deep";
    return false;
  }
  bool leave() {
    --depth_;
    return true;
  }
  int depth_ = 0;
};

const Json* member(const Json& object, const char* name) {
  const auto it = object.find(name);
  return it == object.end() ? nullptr : &*it;
}

const std::string* text(const Json& object, const char* name) {
  const Json* v = member(object, name);
  return v && v->is_string() ? v->get_ptr<const std::string*>() : nullptr;
}

/** A finite number (JSON's integers and floats alike). */
std::optional<double> number(const Json& object, const char* name) {
  const Json* v = member(object, name);
  if (!v || !v->is_number()) return std::nullopt;
  const double d = v->get<double>();
  return std::isfinite(d) ? std::optional<double>(d) : std::nullopt;
}

bool wholeNumber(std::optional<double> d, std::int64_t lo, std::int64_t hi) {
  return d && std::floor(*d) == *d && *d >= static_cast<double>(lo) &&
         *d <= static_cast<double>(hi);
}

/** Percent-encodes everything but RFC 3986's unreserved characters. */
std::string urlEncode(std::string_view s) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += c;
    } else {
      out += '%';
      out += hex[u >> 4];
      out += hex[u & 15];
    }
  }
  return out;
}

} // namespace

namespace {

/** One member of "layers": what describe() needs, or what is wrong with it. */
std::expected<RemoteLayer, std::string> readLayer(const Json& o, std::string_view server) {
  if (!o.is_object()) return std::unexpected("not an object");
  const auto* name = text(o, "name");
  const auto* format = text(o, "format");
  const auto* ext = text(o, "extension");
  const auto delta = number(o, "levelZeroDelta");
  const Json* sector = member(o, "sector");
  if (!name || name->empty() || !format || !ext || !delta || !sector || !sector->is_object())
    return std::unexpected("name, format, extension, levelZeroDelta and sector are required");
  const auto tw = number(o, "tileWidth");
  const auto th = number(o, "tileHeight");
  const auto levels = number(o, "levels");
  if (!wholeNumber(tw, 1, 65536) || !wholeNumber(th, 1, 65536) ||
      !wholeNumber(levels, 1, kMaxLevel + 1))
    return std::unexpected("tileWidth, tileHeight or levels out of range");
  const auto w = number(*sector, "west");
  const auto s = number(*sector, "south");
  const auto e = number(*sector, "east");
  const auto n = number(*sector, "north");
  if (!w || !s || !e || !n) return std::unexpected("sector needs west, south, east, north");
  RemoteLayer l;
  l.name = *name;
  l.dataset.server = std::string(server);
  l.dataset.name = *name;
  l.dataset.mimeType = *format;
  l.dataset.extension = *ext;
  l.dataset.grid = GridSpec{Sector{*w, *s, *e, *n},
                            *delta,
                            static_cast<std::int32_t>(*tw),
                            static_cast<std::int32_t>(*th),
                            static_cast<std::int32_t>(*levels)};
  if (auto g = TileGrid::create(l.dataset.grid); !g) return std::unexpected(g.error());
  if (const Json* el = member(o, "elevation"); el && el->is_boolean())
    l.elevation = el->get<bool>();
  // Whole polar rows and spans served (issue 29; absent from older servers: no).
  if (const Json* wr = member(o, "wholeRows"); wr && wr->is_boolean())
    l.wholeRows = wr->get<bool>();
  // The body (issue 26; absent from older servers: the Earth).
  if (const Json* b = member(o, "body"); b && b->is_string() && !b->get<std::string>().empty())
    l.dataset.body = b->get<std::string>();
  return l;
}

} // namespace

std::expected<std::vector<RemoteLayer>, std::string> parseLayersJson(std::string_view json,
                                                                     std::string_view server) {
  // nlohmann-json reads a NUL byte as the end of the input: whatever followed would be ignored.
  if (const auto nul = json.find('\0'); nul != std::string_view::npos)
    return std::unexpected("JSON: a NUL byte at offset " + std::to_string(nul));
  JsonCheck check;
  if (!Json::sax_parse(json, &check)) return std::unexpected(check.error);
  const Json doc = Json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return std::unexpected("JSON: not valid"); // the check said it was
  if (!doc.is_object()) return std::unexpected("layers.json: the document is not an object");
  const Json* list = member(doc, "layers");
  if (!list || !list->is_array()) return std::unexpected("layers.json: no \"layers\" array");
  std::vector<RemoteLayer> out;
  for (std::size_t i = 0; i < list->size(); ++i) {
    auto l = readLayer((*list)[i], server);
    if (!l) return std::unexpected("layers.json: layer " + std::to_string(i) + ": " + l.error());
    out.push_back(std::move(*l));
  }
  return out;
}

// ------------------------------------------------------------------------------------ source

struct RemoteTileSource::Impl {
  struct Job {
    TileAddress address;
    std::string url;
    Callback done;
  };

  std::string base;
  RemoteSourceOptions options;
  std::vector<RemoteLayer> layers;
  std::vector<TileGrid> grids;

  mutable std::mutex mutex;
  RequestQueue<Job> queue;
  std::size_t inFlight = 0;
  bool closing = false;

  // Answers that need no network (unknown layer, key outside the grid) go out on this thread,
  // started on first use, so that `done` never runs inside request().
  std::condition_variable answerCv;
  std::deque<std::pair<Callback, TileResult>> answers;
  std::thread answerer;

  std::unique_ptr<Fetcher> fetcher; // last: destroyed first, while the rest is alive

  void answerLater(Callback done, TileResult r) {
    std::lock_guard lock(mutex);
    if (closing) return;
    answers.emplace_back(std::move(done), std::move(r));
    if (!answerer.joinable()) answerer = std::thread([this] { answerLoop(); });
    answerCv.notify_one();
  }
  void answerLoop() {
    std::unique_lock lock(mutex);
    for (;;) {
      answerCv.wait(lock, [this] { return closing || !answers.empty(); });
      if (closing) return;
      auto [done, r] = std::move(answers.front());
      answers.pop_front();
      lock.unlock();
      done(std::move(r));
      lock.lock();
    }
  }

  const RemoteLayer* layer(std::string_view name, std::size_t* index = nullptr) const {
    for (std::size_t i = 0; i < layers.size(); ++i)
      if (layers[i].name == name) {
        if (index) *index = i;
        return &layers[i];
      }
    return nullptr;
  }

  /** A layer's whole row or span (`<layer>@caps`, `<layer>@span<k>`): the layer, if it has
   * them, and the suffix; else null. */
  const RemoteLayer*
  wholeBox(std::string_view name, std::size_t* index, std::string_view* suffix) const {
    const auto own = wholeBoxLayer(name);
    if (!own) return nullptr;
    const RemoteLayer* l = layer(*own, index);
    if (!l || !l->wholeRows) return nullptr;
    *suffix = name.substr(own->size());
    return l;
  }

  std::string url(const TileAddress& a) const {
    std::size_t i = 0;
    std::string_view suffix; // '@' is a path character: sent as it is
    const RemoteLayer* l = layer(a.layer, &i);
    if (!l) l = wholeBox(a.layer, &i, &suffix);
    if (!l || !grids[i].isValid(a.key)) return {};
    const TileKey& k = a.key;
    std::string u = base + "/tiles/" + urlEncode(l->name) + std::string(suffix) + "/" +
                    std::to_string(k.level) + "/" + std::to_string(k.row) + "/" +
                    std::to_string(k.row) + "_" + std::to_string(k.col) + "." +
                    l->dataset.extension;
    if (!a.time.empty()) u += "?time=" + urlEncode(a.time);
    return u;
  }

  static TileResult toResult(FetchResult&& r) {
    TileResult out;
    if (!r) {
      out.status = TileStatus::Failed;
      out.message = std::string(toString(r.error().code)) + ": " + r.error().message;
      return out;
    }
    if (r->status == 200 && !r->body.empty()) {
      out.status = TileStatus::Ok;
      out.bytes = std::move(r->body);
      out.contentType = std::move(r->contentType);
      return out;
    }
    out.status = r->status == 404 ? TileStatus::Absent : TileStatus::Failed;
    out.message = "HTTP " + std::to_string(r->status) + ": " +
                  std::string(reinterpret_cast<const char*>(r->body.data()),
                              std::min<std::size_t>(r->body.size(), 200));
    while (!out.message.empty() && (out.message.back() == '\n' || out.message.back() == '\r'))
      out.message.pop_back();
    return out;
  }

  /** Puts queued jobs on the wire up to the cap. Called without the lock held. */
  void pump() {
    std::vector<Job> start;
    {
      std::lock_guard lock(mutex);
      while (!closing && inFlight < options.maxInFlight) {
        auto j = queue.pop();
        if (!j) break;
        ++inFlight;
        start.push_back(std::move(j->second));
      }
    }
    for (Job& j : start) {
      FetchRequest req;
      req.upstream = "remote";
      req.url = j.url;
      fetcher->fetch(std::move(req), [this, done = std::move(j.done)](FetchResult&& r) mutable {
        {
          std::lock_guard lock(mutex);
          --inFlight;
          if (closing) return; // being destroyed: dropped, like queued requests
        }
        done(toResult(std::move(r)));
        pump();
      });
    }
  }
};

RemoteTileSource::RemoteTileSource(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}

RemoteTileSource::~RemoteTileSource() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->closing = true;
    impl_->queue.clear();
    impl_->answers.clear();
  }
  impl_->answerCv.notify_all();
  if (impl_->answerer.joinable()) impl_->answerer.join();
  impl_->fetcher.reset(); // completes what is on the wire (dropped) and joins its thread
}

std::expected<std::unique_ptr<RemoteTileSource>, std::string>
RemoteTileSource::connect(const std::string& baseUrl, RemoteSourceOptions options) {
  std::string base = baseUrl;
  while (!base.empty() && base.back() == '/')
    base.pop_back();
  if (!base.starts_with("http://") && !base.starts_with("https://"))
    return std::unexpected("remote tile source: " + baseUrl + " is not an http(s) URL");
  if (options.maxInFlight == 0) options.maxInFlight = 1;
  auto impl = std::make_shared<Impl>();
  impl->base = base;
  impl->options = options;
  impl->fetcher = std::make_unique<Fetcher>(options.maxInFlight + 1);
  UpstreamPolicy policy;
  policy.maxConnections = static_cast<int>(options.maxInFlight);
  policy.connectTimeout = options.connectTimeout;
  policy.timeout = options.timeout;
  policy.retries = options.retries;
  impl->fetcher->setPolicy("remote", policy);

  std::promise<FetchResult> answer;
  auto future = answer.get_future();
  impl->fetcher->fetch(FetchRequest{"remote", base + "/layers.json", {}, {}},
                       [&answer](FetchResult&& r) { answer.set_value(std::move(r)); });
  FetchResult r = future.get();
  const std::string what = base + "/layers.json";
  if (!r) return std::unexpected(what + ": " + toString(r.error().code) + ": " + r.error().message);
  if (r->status != 200)
    return std::unexpected(what + ": HTTP " + std::to_string(r->status) +
                           " (is this a tellus serve?)");
  const std::string_view body(reinterpret_cast<const char*>(r->body.data()), r->body.size());
  std::string server = base.substr(base.find("://") + 3);
  if (const auto slash = server.find('/'); slash != std::string::npos) server.resize(slash);
  auto layers = parseLayersJson(body, server);
  if (!layers) return std::unexpected(what + ": " + layers.error());
  impl->layers = std::move(*layers);
  for (const RemoteLayer& l : impl->layers)
    impl->grids.push_back(*TileGrid::create(l.dataset.grid));
  return std::unique_ptr<RemoteTileSource>(new RemoteTileSource(std::move(impl)));
}

bool RemoteTileSource::wholePolarRows(std::string_view layer) const {
  const RemoteLayer* l = impl_->layer(layer);
  return l && l->wholeRows;
}

const std::vector<RemoteLayer>& RemoteTileSource::layers() const noexcept {
  return impl_->layers;
}

std::optional<DatasetSpec> RemoteTileSource::describe(std::string_view layer,
                                                      std::string_view time) const {
  const RemoteLayer* l = impl_->layer(layer);
  if (!l) return std::nullopt;
  DatasetSpec d = l->dataset;
  d.time = std::string(time);
  return d;
}

TileRequestId
RemoteTileSource::request(const TileAddress& address, double priority, Callback done) {
  std::string url = impl_->url(address);
  if (url.empty()) {
    TileResult r;
    std::size_t i = 0;
    std::string_view suffix;
    const bool known = impl_->layer(address.layer) || impl_->wholeBox(address.layer, &i, &suffix);
    r.status = known ? TileStatus::Absent : TileStatus::Failed;
    r.message = r.status == TileStatus::Absent ? "outside the layer's grid"
                                               : "no layer " + address.layer + " on the server";
    impl_->answerLater(std::move(done), std::move(r));
    return 0;
  }
  TileRequestId id = 0;
  {
    std::lock_guard lock(impl_->mutex);
    id = impl_->queue.push(priority, Impl::Job{address, std::move(url), std::move(done)});
  }
  impl_->pump();
  return id;
}

void RemoteTileSource::reprioritize(TileRequestId id, double priority) {
  std::lock_guard lock(impl_->mutex);
  impl_->queue.reprioritize(id, priority);
}

bool RemoteTileSource::cancel(TileRequestId id) {
  std::lock_guard lock(impl_->mutex);
  return impl_->queue.cancel(id);
}

std::string RemoteTileSource::tileUrl(const TileAddress& address) const {
  return impl_->url(address);
}

std::size_t RemoteTileSource::queued() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->queue.size();
}

} // namespace tellus
