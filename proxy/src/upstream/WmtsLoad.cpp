// A WMTS upstream's capabilities fetched at start and kept on disk (WmtsUpstream.hpp).

#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/WmtsUpstream.hpp>

#include <fstream>
#include <future>
#include <sstream>
#include <system_error>
#include <unistd.h>

namespace tellus {

namespace fs = std::filesystem;

namespace {

std::optional<std::string> readFile(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/** Written whole or not at all: a temp file beside it, renamed into place. */
void writeFile(const fs::path& file, std::string_view text) {
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  const fs::path tmp = file.string() + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (!out) {
      fs::remove(tmp, ec);
      return;
    }
  }
  fs::rename(tmp, file, ec);
  if (ec) fs::remove(tmp, ec);
}

/** The body of a 200 answer, or why there is none. */
std::expected<std::string, std::string>
fetchText(Fetcher& fetcher, const std::string& name, const std::string& url) {
  std::promise<FetchResult> promise;
  auto future = promise.get_future();
  fetcher.fetch(FetchRequest{name, url, {}, {}},
                [&promise](FetchResult&& r) { promise.set_value(std::move(r)); });
  FetchResult r = future.get();
  if (!r) return std::unexpected(url + ": " + r.error().message);
  if (r->status != 200) return std::unexpected(url + ": HTTP " + std::to_string(r->status));
  return std::string(reinterpret_cast<const char*>(r->body.data()), r->body.size());
}

} // namespace

fs::path wmtsCapabilitiesFile(const fs::path& cacheRoot, std::string_view upstream) {
  return cacheRoot / "wmts-capabilities" / (std::string(upstream) + ".xml");
}

std::expected<WmtsCapabilities, std::string> loadWmtsCapabilities(Fetcher& fetcher,
                                                                  const std::string& name,
                                                                  const std::string& url,
                                                                  const fs::path& file,
                                                                  bool offline,
                                                                  std::string* note) {
  std::string why;
  if (!offline) {
    const std::string capsUrl = wmtsCapabilitiesUrl(url);
    auto text = fetchText(fetcher, name, capsUrl);
    if (text) {
      auto caps = parseWmtsCapabilities(*text);
      if (caps) {
        writeFile(file, *text);
        return caps;
      }
      why = capsUrl + ": " + caps.error();
    } else {
      why = text.error();
    }
  } else {
    why = "offline";
  }
  const auto saved = readFile(file);
  if (!saved)
    return std::unexpected("cannot read the WMTS capabilities (" + why +
                           ") and no copy is saved at " + file.string());
  auto caps = parseWmtsCapabilities(*saved);
  if (!caps)
    return std::unexpected("cannot read the WMTS capabilities (" + why +
                           ") and the copy saved at " + file.string() + " is bad: " + caps.error());
  if (note && !offline)
    *note = "WMTS capabilities from the copy saved at " + file.string() + " (" + why + ")";
  return caps;
}

} // namespace tellus
