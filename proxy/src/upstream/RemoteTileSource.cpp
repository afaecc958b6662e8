#include <tellus/cache/RequestQueue.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>

#include <cctype>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <future>
#include <map>
#include <mutex>
#include <thread>
#include <utility>
#include <variant>

namespace tellus {

// ------------------------------------------------------------------------------------ JSON
// Just enough JSON for /layers.json: objects, arrays, strings (with escapes), numbers, booleans,
// null. Depth-limited; any syntax error is reported with its offset.
namespace {

struct JsonValue;
using JsonObject = std::map<std::string, JsonValue, std::less<>>;
using JsonArray = std::vector<JsonValue>;
struct JsonValue {
  std::variant<std::nullptr_t, bool, double, std::string, JsonArray, JsonObject> v;
};

class JsonParser {
public:
  explicit JsonParser(std::string_view s) : s_(s) {}

  std::expected<JsonValue, std::string> parseDocument() {
    auto v = value(0);
    if (!v) return v;
    ws();
    if (p_ != s_.size()) return fail("trailing characters");
    return v;
  }

private:
  std::unexpected<std::string> fail(std::string_view what) const {
    return std::unexpected("JSON: " + std::string(what) + " at offset " + std::to_string(p_));
  }
  void ws() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\n' || s_[p_] == '\r' || s_[p_] == '\t'))
      ++p_;
  }
  bool literal(std::string_view word) {
    if (s_.substr(p_, word.size()) != word) return false;
    p_ += word.size();
    return true;
  }
  std::expected<JsonValue, std::string> value(int depth) {
    if (depth > 32) return fail("nested too deeply");
    ws();
    if (p_ >= s_.size()) return fail("unexpected end");
    const char c = s_[p_];
    if (c == '{') return object(depth);
    if (c == '[') return array(depth);
    if (c == '"') {
      auto str = string();
      if (!str) return std::unexpected(str.error());
      return JsonValue{std::move(*str)};
    }
    if (literal("true")) return JsonValue{true};
    if (literal("false")) return JsonValue{false};
    if (literal("null")) return JsonValue{nullptr};
    return number();
  }
  std::expected<JsonValue, std::string> number() {
    const std::size_t start = p_;
    while (p_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[p_])) || s_[p_] == '-' ||
                              s_[p_] == '+' || s_[p_] == '.' || s_[p_] == 'e' || s_[p_] == 'E'))
      ++p_;
    double d = 0;
    const auto r = std::from_chars(s_.data() + start, s_.data() + p_, d);
    if (start == p_ || r.ec != std::errc() || r.ptr != s_.data() + p_ || !std::isfinite(d)) {
      p_ = start;
      return fail("not a value");
    }
    return JsonValue{d};
  }
  std::expected<std::string, std::string> string() {
    ++p_; // opening quote
    std::string out;
    while (p_ < s_.size()) {
      const char c = s_[p_++];
      if (c == '"') return out;
      if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (p_ >= s_.size()) break;
      const char e = s_[p_++];
      switch (e) {
      case '"':
        out += '"';
        break;
      case '\\':
        out += '\\';
        break;
      case '/':
        out += '/';
        break;
      case 'b':
        out += '\b';
        break;
      case 'f':
        out += '\f';
        break;
      case 'n':
        out += '\n';
        break;
      case 'r':
        out += '\r';
        break;
      case 't':
        out += '\t';
        break;
      case 'u': {
        unsigned cp = 0;
        if (p_ + 4 > s_.size() ||
            std::from_chars(s_.data() + p_, s_.data() + p_ + 4, cp, 16).ptr != s_.data() + p_ + 4)
          return fail("bad \\u escape");
        p_ += 4;
        if (cp >= 0xD800 && cp <= 0xDBFF && s_.substr(p_, 2) == "\\u") {
          unsigned lo = 0;
          if (p_ + 6 <= s_.size() &&
              std::from_chars(s_.data() + p_ + 2, s_.data() + p_ + 6, lo, 16).ptr ==
                  s_.data() + p_ + 6 &&
              lo >= 0xDC00 && lo <= 0xDFFF) {
            cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
            p_ += 6;
          }
        }
        if (cp < 0x80) {
          out += static_cast<char>(cp);
        } else if (cp < 0x800) {
          out += static_cast<char>(0xC0 | (cp >> 6));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
          out += static_cast<char>(0xE0 | (cp >> 12));
          out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        } else {
          out += static_cast<char>(0xF0 | (cp >> 18));
          out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
          out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        }
        break;
      }
      default:
        return fail("bad escape");
      }
    }
    return fail("unterminated string");
  }
  std::expected<JsonValue, std::string> array(int depth) {
    ++p_;
    JsonArray a;
    ws();
    if (p_ < s_.size() && s_[p_] == ']') {
      ++p_;
      return JsonValue{std::move(a)};
    }
    for (;;) {
      auto v = value(depth + 1);
      if (!v) return v;
      a.push_back(std::move(*v));
      ws();
      if (p_ < s_.size() && s_[p_] == ',') {
        ++p_;
        continue;
      }
      if (p_ < s_.size() && s_[p_] == ']') {
        ++p_;
        return JsonValue{std::move(a)};
      }
      return fail("expected , or ]");
    }
  }
  std::expected<JsonValue, std::string> object(int depth) {
    ++p_;
    JsonObject o;
    ws();
    if (p_ < s_.size() && s_[p_] == '}') {
      ++p_;
      return JsonValue{std::move(o)};
    }
    for (;;) {
      ws();
      if (p_ >= s_.size() || s_[p_] != '"') return fail("expected a member name");
      auto key = string();
      if (!key) return std::unexpected(key.error());
      ws();
      if (p_ >= s_.size() || s_[p_] != ':') return fail("expected :");
      ++p_;
      auto v = value(depth + 1);
      if (!v) return v;
      o.insert_or_assign(std::move(*key), std::move(*v));
      ws();
      if (p_ < s_.size() && s_[p_] == ',') {
        ++p_;
        continue;
      }
      if (p_ < s_.size() && s_[p_] == '}') {
        ++p_;
        return JsonValue{std::move(o)};
      }
      return fail("expected , or }");
    }
  }

  std::string_view s_;
  std::size_t p_ = 0;
};

template <class T> const T* member(const JsonObject& o, std::string_view name) {
  const auto it = o.find(name);
  return it == o.end() ? nullptr : std::get_if<T>(&it->second.v);
}

bool wholeNumber(const double* d, std::int64_t lo, std::int64_t hi) {
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

std::expected<std::vector<RemoteLayer>, std::string> parseLayersJson(std::string_view json,
                                                                     std::string_view server) {
  auto doc = JsonParser(json).parseDocument();
  if (!doc) return std::unexpected(doc.error());
  const auto* root = std::get_if<JsonObject>(&doc->v);
  if (!root) return std::unexpected("layers.json: the document is not an object");
  const auto* list = member<JsonArray>(*root, "layers");
  if (!list) return std::unexpected("layers.json: no \"layers\" array");
  std::vector<RemoteLayer> out;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const auto where = "layers.json: layer " + std::to_string(i) + ": ";
    const auto* o = std::get_if<JsonObject>(&(*list)[i].v);
    if (!o) return std::unexpected(where + "not an object");
    const auto* name = member<std::string>(*o, "name");
    const auto* format = member<std::string>(*o, "format");
    const auto* ext = member<std::string>(*o, "extension");
    const auto* delta = member<double>(*o, "levelZeroDelta");
    const auto* tw = member<double>(*o, "tileWidth");
    const auto* th = member<double>(*o, "tileHeight");
    const auto* levels = member<double>(*o, "levels");
    const auto* sector = member<JsonObject>(*o, "sector");
    if (!name || name->empty() || !format || !ext || !delta || !sector)
      return std::unexpected(where +
                             "name, format, extension, levelZeroDelta and sector are required");
    if (!wholeNumber(tw, 1, 65536) || !wholeNumber(th, 1, 65536) ||
        !wholeNumber(levels, 1, kMaxLevel + 1))
      return std::unexpected(where + "tileWidth, tileHeight or levels out of range");
    const auto* w = member<double>(*sector, "west");
    const auto* s = member<double>(*sector, "south");
    const auto* e = member<double>(*sector, "east");
    const auto* n = member<double>(*sector, "north");
    if (!w || !s || !e || !n)
      return std::unexpected(where + "sector needs west, south, east, north");
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
    if (auto g = TileGrid::create(l.dataset.grid); !g) return std::unexpected(where + g.error());
    if (const auto* el = member<bool>(*o, "elevation")) l.elevation = *el;
    out.push_back(std::move(l));
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

  std::string url(const TileAddress& a) const {
    std::size_t i = 0;
    const RemoteLayer* l = layer(a.layer, &i);
    if (!l || !grids[i].isValid(a.key)) return {};
    const TileKey& k = a.key;
    std::string u = base + "/tiles/" + urlEncode(l->name) + "/" + std::to_string(k.level) + "/" +
                    std::to_string(k.row) + "/" + std::to_string(k.row) + "_" +
                    std::to_string(k.col) + "." + l->dataset.extension;
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
    r.status = impl_->layer(address.layer) ? TileStatus::Absent : TileStatus::Failed;
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
