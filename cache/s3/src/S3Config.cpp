// s3:// URLs and where the credentials come from (never echoed in a message).

#include <tellus/cache_s3/S3TileStore.hpp>

#include <cstdlib>
#include <fstream>

namespace tellus {

std::expected<S3Url, CacheError> parseS3Url(std::string_view url) {
  const auto bad = [&](std::string_view why) {
    return std::unexpected(CacheError{CacheErrc::InvalidArgument,
                                      "bad S3 URL '" + std::string(url) + "': " + std::string(why) +
                                          " (expected s3://BUCKET[/PREFIX])"});
  };
  constexpr std::string_view kScheme = "s3://";
  if (!url.starts_with(kScheme)) return bad("not s3://");
  std::string_view rest = url.substr(kScheme.size());
  const auto slash = rest.find('/');
  S3Url out;
  out.bucket = std::string(rest.substr(0, slash));
  if (out.bucket.empty()) return bad("no bucket");
  for (const char c : out.bucket) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '.';
    if (!ok) return bad("a bucket name is lower-case letters, digits, '-' and '.'");
  }
  if (slash != std::string_view::npos) {
    std::string_view prefix = rest.substr(slash + 1);
    while (prefix.ends_with('/'))
      prefix.remove_suffix(1);
    if (prefix.find("//") != std::string_view::npos) return bad("empty prefix segment");
    for (const char c : prefix) {
      if (static_cast<unsigned char>(c) < 0x20 || c == '?' || c == '#' || c == '\\')
        return bad("the prefix holds a control character, '?', '#' or '\\'");
    }
    out.prefix = std::string(prefix);
  }
  return out;
}

namespace {

std::string trim(std::string s) {
  const auto a = s.find_first_not_of(" \t\r");
  const auto b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

} // namespace

std::expected<S3Credentials, CacheError>
s3CredentialsFromEnvironment(const std::filesystem::path& file) {
  const char* id = std::getenv("AWS_ACCESS_KEY_ID");
  const char* secret = std::getenv("AWS_SECRET_ACCESS_KEY");
  if (id && *id && secret && *secret) return S3Credentials{id, secret};
  std::filesystem::path path = file;
  if (path.empty()) {
    if (const char* f = std::getenv("AWS_SHARED_CREDENTIALS_FILE"); f && *f)
      path = f;
    else if (const char* home = std::getenv("HOME"); home && *home)
      path = std::filesystem::path(home) / ".aws" / "credentials";
  }
  const char* p = std::getenv("AWS_PROFILE");
  const std::string profile = p && *p ? p : "default";
  std::ifstream in(path);
  S3Credentials out;
  bool inProfile = false;
  for (std::string line; in && std::getline(in, line);) {
    line = trim(line);
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line.front() == '[') {
      inProfile = trim(line.substr(1, line.find(']') - 1)) == profile;
      continue;
    }
    const auto eq = line.find('=');
    if (!inProfile || eq == std::string::npos) continue;
    const std::string name = trim(line.substr(0, eq));
    if (name == "aws_access_key_id") out.accessKeyId = trim(line.substr(eq + 1));
    if (name == "aws_secret_access_key") out.secretAccessKey = trim(line.substr(eq + 1));
  }
  if (!out.accessKeyId.empty() && !out.secretAccessKey.empty()) return out;
  return std::unexpected(
      CacheError{CacheErrc::InvalidArgument,
                 "no S3 credentials: set AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY, or put "
                 "aws_access_key_id and aws_secret_access_key in the [" +
                     profile + "] section of " +
                     (path.empty() ? std::string("~/.aws/credentials") : path.string())});
}

} // namespace tellus
