// YAML -> Config: the document (one, a mapping), its top level (cache, data_dir) and the sections
// in the order they are read (ParseSections.hpp); yaml-cpp's exceptions and ours (Failure) never
// leave parseDocument(): every problem becomes a ConfigError with the file, the line, the column
// and the dotted key.

#include "EmbeddedDefaultYaml.hpp"
#include "ParseSections.hpp"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace tellus {

namespace {

using namespace detail::yaml;
namespace fs = std::filesystem;

constexpr std::string_view kEmbeddedName = "<embedded default.yaml>";
constexpr std::uintmax_t kMaxFileBytes = 16U << 20;

void readCache(Reader& r, const Map& root, const fs::path& baseDir, CacheSettings& c) {
  const auto [node, where] = root.child("cache");
  const Map m(
      r,
      node,
      root.path("cache"),
      where,
      {"root", "size_limit", "keep_unstored", "index", "index_password_file", "store", "s3"});
  std::string rootText;
  if (auto v = m.get("root")) rootText = text(r, *v, m.path("root"));
  c.root = rootText.empty() ? defaultCacheRoot() : resolvePath(rootText, baseDir);
  if (auto v = m.get("size_limit")) c.sizeLimitBytes = size(r, *v, m.path("size_limit"));
  if (auto v = m.get("keep_unstored")) c.keepUnstoredBytes = size(r, *v, m.path("keep_unstored"));
  if (auto v = m.get("index")) {
    c.index = text(r, *v, m.path("index"));
    if (auto bad = checkIndexUri(c.index)) r.fail(v->Mark(), m.path("index"), *bad);
  }
  if (auto v = m.get("index_password_file")) {
    c.indexPasswordFile = resolvePath(text(r, *v, m.path("index_password_file")), baseDir);
    if (c.index.empty())
      r.fail(v->Mark(), m.path("index_password_file"), "needs cache.index (a postgresql:// URI)");
  }
  if (auto v = m.get("store")) {
    c.store = text(r, *v, m.path("store"));
    if (!c.store.empty() && !c.store.starts_with("s3://"))
      r.fail(v->Mark(),
             m.path("store"),
             "store must be s3://BUCKET[/PREFIX] (or absent: tiles under cache.root), got '" +
                 c.store + "'");
  }
  const auto [sn, swhere] = m.child("s3");
  const Map sm(r,
               sn,
               m.path("s3"),
               swhere,
               {"endpoint", "region", "credentials_file", "local_tier", "local_tier_limit"});
  if (auto v = sm.get("endpoint")) {
    c.s3.endpoint = text(r, *v, sm.path("endpoint"));
    while (c.s3.endpoint.ends_with('/'))
      c.s3.endpoint.pop_back();
    if (c.s3.endpoint.find('@') != std::string::npos) // not echoed: it may hold a password
      r.fail(v->Mark(),
             sm.path("endpoint"),
             "endpoint must not hold a user or a password: S3 credentials come from "
             "AWS_ACCESS_KEY_ID/AWS_SECRET_ACCESS_KEY or a credentials file");
    const bool http = c.s3.endpoint.starts_with("http://") || c.s3.endpoint.starts_with("https://");
    if (!http || c.s3.endpoint.find('/', c.s3.endpoint.find("//") + 2) != std::string::npos)
      r.fail(v->Mark(),
             sm.path("endpoint"),
             "endpoint must be http(s)://HOST[:PORT] with no path and no user, got '" +
                 c.s3.endpoint + "'");
  }
  if (auto v = sm.get("region")) c.s3.region = text(r, *v, sm.path("region"));
  if (auto v = sm.get("credentials_file"))
    c.s3.credentialsFile = resolvePath(text(r, *v, sm.path("credentials_file")), baseDir);
  if (auto v = sm.get("local_tier")) c.s3.localTier = boolean(r, *v, sm.path("local_tier"));
  if (auto v = sm.get("local_tier_limit")) {
    c.s3.localTierLimitBytes = size(r, *v, sm.path("local_tier_limit"));
    if (c.store.empty())
      r.fail(v->Mark(),
             sm.path("local_tier_limit"),
             "local_tier_limit bounds the local copies in front of cache.store (s3://...), and "
             "there is no cache.store: cache.size_limit bounds a cache of its own");
    else if (!c.s3.localTier && c.s3.localTierLimitBytes > 0)
      r.fail(v->Mark(),
             sm.path("local_tier_limit"),
             "local_tier_limit bounds the local tier, and cache.s3.local_tier is false");
  }
  if (!c.store.empty() && c.sizeLimitBytes > 0)
    r.fail(node.Mark(),
           m.path("size_limit"),
           "size_limit evicts tiles from the store, here the bucket other instances share: bound "
           "this instance's local copies with cache.s3.local_tier_limit instead");
  if (!c.store.empty() && c.s3.endpoint.empty())
    r.fail(
        node.Mark(), m.path("s3"), "cache.store is " + c.store + ": cache.s3.endpoint is needed");
}

struct ParseOptions {
  bool checkFiles = true;
  const fs::path* dataDirOverride = nullptr; ///< the embedded default: its data_dir
};

Config build(Reader& r, const YAML::Node& doc, const fs::path& baseDir, const ParseOptions& o) {
  if (doc.IsNull())
    r.fail(doc.Mark().is_null() ? YAML::Mark() : doc.Mark(),
           "",
           "the document is empty: it needs at least 'upstreams' and 'layers'");
  if (!doc.IsMap())
    r.fail(doc.Mark(),
           "",
           "the top level must be a mapping (server, cache, data_dir, upstreams, layers), got " +
               describe(doc));
  const Map root(r,
                 doc,
                 "",
                 doc.Mark(),
                 {"server", "cache", "renderer", "bodies", "data_dir", "upstreams", "layers"});
  Config c;
  readServer(r, root, c.server);
  readCache(r, root, baseDir, c.cache);
  readRenderer(r, root, c.renderer);
  readBodies(r, root, c.bodies);

  fs::path dataDir = baseDir;
  if (auto v = root.get("data_dir")) dataDir = resolvePath(text(r, *v, "data_dir"), baseDir);
  if (o.dataDirOverride) dataDir = *o.dataDirOverride;

  const auto upstreams = list(r, root.need("upstreams"), "upstreams");
  for (std::size_t i = 0; i < upstreams.size(); ++i) {
    const std::string p = indexPath("upstreams", i);
    r.remember(p, upstreams[i].Mark());
    c.upstreams.push_back(readUpstream(r, upstreams[i], p, dataDir));
  }
  const YAML::Node layersNode = root.need("layers");
  const auto layers = list(r, layersNode, "layers");
  if (layers.empty()) r.fail(layersNode.Mark(), "layers", "the list of layers is empty");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const std::string p = indexPath("layers", i);
    r.remember(p, layers[i].Mark());
    c.layers.push_back(readLayer(r, layers[i], p));
  }
  if (auto issue = detail::findIssue(c, o.checkFiles))
    r.fail(r.markFor(issue->key), issue->key, issue->withSubject());
  return c;
}

/** A document of a YAML stream: where it starts (its first token) and where its root node is. */
struct DocumentMarks {
  YAML::Mark start;
  YAML::Mark root;
};

/** The documents of a YAML stream, up to the first one that starts where the one before it did.
 *
 * yaml-cpp 0.7 (Debian 12) does not consume a token that cannot start a node at the top level (a
 * stray ',' as in ", a" or "a: 1\n,\n"): it reports an empty document and leaves the token, so the
 * next document starts at the same place, and YAML::LoadAll loops forever, allocating until the
 * memory is gone (yaml-cpp issue #1040, fixed after 0.7; found by fuzz/FuzzConfig.cpp). Two
 * documents starting at the same position mean exactly that. */
std::vector<DocumentMarks> documentMarks(const std::string& text) {
  class Handler final : public YAML::EventHandler {
  public:
    std::vector<DocumentMarks> docs;
    void OnDocumentStart(const YAML::Mark& m) override {
      docs.push_back({m, m});
      nodes_ = 0;
    }
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
    void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
    void
    OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override {
      node(m);
    }
    void OnSequenceStart(const YAML::Mark& m,
                         const std::string&,
                         YAML::anchor_t,
                         YAML::EmitterStyle::value) override {
      node(m);
    }
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark& m,
                    const std::string&,
                    YAML::anchor_t,
                    YAML::EmitterStyle::value) override {
      node(m);
    }
    void OnMapEnd() override {}

  private:
    void node(const YAML::Mark& m) {
      if (nodes_++ == 0 && !docs.empty()) docs.back().root = m;
    }
    std::size_t nodes_ = 0; // of the current document; the first is its root
  };
  Handler h;
  std::istringstream in(text);
  YAML::Parser parser(in);
  // Every other document consumes at least one token, so this ends.
  while (parser.HandleNextDocument(h)) {
    const auto& d = h.docs;
    if (d.size() >= 2 && d[d.size() - 1].start.pos == d[d.size() - 2].start.pos) break;
  }
  return std::move(h.docs);
}

std::expected<Config, ConfigError> parseDocument(std::string_view yamlText,
                                                 std::string_view sourceName,
                                                 const fs::path& baseDir,
                                                 const ParseOptions& o) {
  Reader r{std::string(sourceName)};
  try {
    YAML::Node doc;
    try {
      const std::string text(yamlText);
      // One document: counted first (YAML::LoadAll can loop forever, see documentMarks), then
      // loaded with YAML::Load, which reads only the first.
      const std::vector<DocumentMarks> docs = documentMarks(text);
      if (docs.empty())
        r.fail(YAML::Mark(), "", "the file is empty: it needs at least 'upstreams' and 'layers'");
      if (docs.size() >= 2 && docs.back().start.pos == docs[docs.size() - 2].start.pos)
        r.fail(docs.back().start, "", "YAML syntax: unexpected character here (a stray ','?)");
      if (docs.size() > 1)
        r.fail(docs[1].root, "", "more than one YAML document (---): put everything in one");
      doc = YAML::Load(text);
    } catch (const YAML::DeepRecursion& e) {
      r.fail(e.mark, "", "YAML syntax: nested too deeply");
    } catch (const YAML::Exception& e) {
      // yaml-cpp says "bad file" when its scanner gives up, e.g. on thousands of nested brackets.
      r.fail(e.mark,
             "",
             e.msg == "bad file" ? "YAML syntax: cannot parse this (nested too deeply?)"
                                 : "YAML syntax: " + e.msg);
    }
    Config c = build(r, doc, baseDir, o);
    c.sourceFile = fs::path(sourceName);
    return c;
  } catch (const Failure& f) {
    return std::unexpected(f.error);
  } catch (const YAML::Exception& e) {
    ConfigError err{std::string(sourceName), e.mark.line + 1, e.mark.column + 1, "", e.msg};
    return std::unexpected(std::move(err));
  } catch (const std::exception& e) {
    return std::unexpected(ConfigError{std::string(sourceName), 0, 0, "", e.what()});
  }
}

} // namespace

std::expected<Config, ConfigError>
parseConfig(std::string_view yamlText, std::string_view sourceName, const fs::path& baseDir) {
  return parseDocument(yamlText, sourceName, baseDir, ParseOptions{});
}

std::expected<Config, ConfigError> loadConfig(const fs::path& file) {
  const auto error = [&](std::string message) {
    return std::unexpected(ConfigError{file.string(), 0, 0, "", std::move(message)});
  };
  std::error_code ec;
  const auto st = fs::status(file, ec);
  if (!fs::exists(st)) return error("cannot read the configuration: no such file");
  if (fs::is_directory(st)) return error("cannot read the configuration: it is a directory");
  const auto bytes = fs::file_size(file, ec);
  if (!ec && bytes > kMaxFileBytes)
    return error("the configuration is larger than 16 MiB (" + std::to_string(bytes) + " bytes)");
  std::ifstream in(file, std::ios::binary);
  if (!in) return error("cannot open the configuration for reading");
  std::string yaml;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    yaml.append(buf, static_cast<std::size_t>(in.gcount()));
    if (yaml.size() > kMaxFileBytes) return error("the configuration is larger than 16 MiB");
  }
  if (in.bad()) return error("reading the configuration failed");
  fs::path base = fs::absolute(file, ec).parent_path();
  if (ec) base = file.parent_path();
  return parseDocument(yaml, file.string(), base, ParseOptions{});
}

std::string_view embeddedDefaultYaml() noexcept {
  return detail::kEmbeddedDefaultYaml;
}

Config embeddedDefault(const fs::path& dataDir, const fs::path& cacheRoot) {
  ParseOptions o;
  o.checkFiles = false;
  o.dataDirOverride = &dataDir;
  auto c = parseDocument(detail::kEmbeddedDefaultYaml, kEmbeddedName, dataDir, o);
  if (!c) {
    // A build defect (tests parse the same text): no configuration can come out of it.
    std::fprintf(stderr,
                 "tellus: the embedded default configuration is broken: %s\n",
                 c.error().toString().c_str());
    std::abort();
  }
  if (!cacheRoot.empty()) c->cache.root = cacheRoot;
  return std::move(*c);
}

} // namespace tellus
