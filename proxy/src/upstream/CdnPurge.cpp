// PURGE by surrogate key (CdnPurge.hpp): one blocking libcurl easy transfer per endpoint and batch.
#include <tellus/proxy/CdnPurge.hpp>

#include <curl/curl.h>

#include <algorithm>
#include <memory>

namespace tellus {

namespace {

std::size_t discard(char*, std::size_t size, std::size_t n, void*) {
  return size * n;
}

bool keySafe(const std::string& k) {
  return !k.empty() && std::none_of(k.begin(), k.end(), [](char c) {
    return c == ' ' || c == ',' || static_cast<unsigned char>(c) < 0x21 ||
           static_cast<unsigned char>(c) == 0x7f;
  });
}

PurgeOutcome
purgeOnce(const std::string& endpoint, const std::string& keys, std::chrono::milliseconds timeout) {
  PurgeOutcome out{endpoint, 0, {}};
  std::unique_ptr<CURL, decltype(&curl_easy_cleanup)> h(curl_easy_init(), &curl_easy_cleanup);
  if (!h) {
    out.error = "cannot make a libcurl handle";
    return out;
  }
  const std::string header = "xkey-purge: " + keys;
  curl_slist* headers = curl_slist_append(nullptr, header.c_str());
  std::unique_ptr<curl_slist, decltype(&curl_slist_free_all)> hold(headers, &curl_slist_free_all);
  curl_easy_setopt(h.get(), CURLOPT_URL, endpoint.c_str());
  curl_easy_setopt(h.get(), CURLOPT_CUSTOMREQUEST, "PURGE");
  curl_easy_setopt(h.get(), CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(h.get(), CURLOPT_WRITEFUNCTION, &discard);
  curl_easy_setopt(h.get(), CURLOPT_TIMEOUT_MS, static_cast<long>(timeout.count()));
  curl_easy_setopt(h.get(), CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(h.get(), CURLOPT_PROTOCOLS_STR, "http,https");
  const CURLcode rc = curl_easy_perform(h.get());
  if (rc != CURLE_OK) {
    out.error = curl_easy_strerror(rc);
    return out;
  }
  long status = 0;
  curl_easy_getinfo(h.get(), CURLINFO_RESPONSE_CODE, &status);
  out.status = static_cast<int>(status);
  if (status < 200 || status > 299) out.error = "answered " + std::to_string(status);
  return out;
}

} // namespace

std::vector<PurgeOutcome> purgeKeys(const std::vector<std::string>& endpoints,
                                    const std::vector<std::string>& keys,
                                    std::chrono::milliseconds timeout,
                                    std::size_t batch) {
  std::vector<PurgeOutcome> outcomes;
  for (const std::string& k : keys) {
    if (!keySafe(k)) {
      for (const std::string& e : endpoints)
        outcomes.push_back({e, 0, "a key with a blank, comma or control byte"});
      return outcomes;
    }
  }
  static const CURLcode init = curl_global_init(CURL_GLOBAL_DEFAULT);
  batch = std::max<std::size_t>(1, batch);
  for (const std::string& e : endpoints) {
    PurgeOutcome last{e, 0, {}};
    for (std::size_t i = 0; i < keys.size() && last.ok(); i += batch) {
      std::string joined;
      for (std::size_t j = i; j < std::min(keys.size(), i + batch); ++j)
        joined += (joined.empty() ? "" : " ") + keys[j];
      last = init == CURLE_OK ? purgeOnce(e, joined, timeout)
                              : PurgeOutcome{e, 0, "curl_global_init failed"};
    }
    outcomes.push_back(std::move(last));
  }
  return outcomes;
}

} // namespace tellus
