#pragma once
// The S3 server of this test executable: the one a ctest fixture started (TELLUS_S3_ENV names its
// s3.env), else one started here with tests/support/s3-server.sh and stopped at exit. Once per
// executable, never per test.

#include "../support/TempDir.hpp"

#include <tellus/cache_s3/S3TileStore.hpp>

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>

namespace tellus::test {

class S3Server {
public:
  /** The running server (started on first use); fails the test when none can be had. */
  static S3Server& get() {
    static S3Server server;
    return server;
  }

  bool ok() const { return !env_.empty(); }
  const std::string& error() const { return error_; }
  std::string value(const std::string& name) const {
    const auto it = env_.find(name);
    return it == env_.end() ? std::string() : it->second;
  }

  /** Options for a store under `prefix` with its local folder `local`. */
  S3TileStoreOptions options(const std::string& prefix, const std::filesystem::path& local) const {
    S3TileStoreOptions o;
    o.endpoint = value("S3_ENDPOINT");
    o.region = value("S3_REGION");
    o.location = S3Url{value("S3_BUCKET"), prefix};
    o.credentials = S3Credentials{value("AWS_ACCESS_KEY_ID"), value("AWS_SECRET_ACCESS_KEY")};
    o.localFolder = local;
    return o;
  }

  ~S3Server() {
    if (!ownDir_.empty()) {
      const std::string cmd = script() + " stop '" + ownDir_ + "' >/dev/null 2>&1";
      [[maybe_unused]] const int rc = std::system(cmd.c_str());
    }
  }

private:
  S3Server() {
    std::string file;
    if (const char* f = std::getenv("TELLUS_S3_ENV"); f && *f) {
      file = f;
    } else {
      ownDir_ = std::string(TELLUS_TEST_TMP_DIR) + "/s3-" + std::to_string(::getpid());
      const std::string cmd = script() + " start '" + ownDir_ + "' > '" + ownDir_ + ".log' 2>&1";
      if (std::system(cmd.c_str()) != 0) {
        error_ = "tests/support/s3-server.sh failed (see " + ownDir_ + ".log)";
        ownDir_.clear();
        return;
      }
      file = ownDir_ + "/s3.env";
    }
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) {
      const auto eq = line.find('=');
      if (eq == std::string::npos) continue;
      std::string v = line.substr(eq + 1);
      if (v.size() >= 2 && v.front() == '"') v = v.substr(1, v.size() - 2);
      env_[line.substr(0, eq)] = v;
    }
    if (env_.empty()) error_ = "no S3 server: " + file + " is empty or missing";
  }

  static std::string script() {
    return std::string(TELLUS_TEST_SOURCE_DIR) + "/support/s3-server.sh";
  }

  std::map<std::string, std::string> env_;
  std::string error_;
  std::string ownDir_;
};

/** A key prefix no other test (or run) uses. */
inline std::string uniquePrefix(const std::string& what) {
  static int n = 0;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "x";
  for (char& c : name)
    if (c == '/') c = '_';
  return "t" + std::to_string(::getpid()) + "-" + std::to_string(++n) + "/" + name + "/" + what;
}

} // namespace tellus::test
