#include "PgServer.hpp"

#include "../support/TempDir.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <libpq-fe.h>
#include <memory>
#include <unistd.h>

namespace tellus::test {

namespace {

const std::string kScript = std::string(TELLUS_TEST_SOURCE_DIR) + "/support/postgres.sh";

/** A server this process started (none when the ctest fixture's is used). */
struct OwnServer {
  std::string dir;
  std::string uri;
  ~OwnServer() {
    if (!dir.empty()) std::system(("'" + kScript + "' stop '" + dir + "'").c_str());
  }
};

std::string readUri() {
  if (const char* file = std::getenv("TELLUS_TEST_PG_URI_FILE")) {
    std::ifstream in(file);
    std::string uri;
    if (std::getline(in, uri) && !uri.empty()) return uri;
  }
  static OwnServer own;
  own.dir = std::string(TELLUS_TEST_TMP_DIR) + "/pg-" + std::to_string(::getpid());
  const std::string cmd = "'" + kScript + "' stop '" + own.dir + "' && '" + kScript + "' start '" +
                          own.dir + "' >/dev/null";
  if (std::system(cmd.c_str()) != 0) return {};
  std::ifstream in(own.dir + "/uri");
  std::getline(in, own.uri);
  return own.uri;
}

} // namespace

const std::string& pgAdminUri() {
  static const std::string uri = readUri();
  return uri;
}

std::string pgUriOf(const std::string& name) {
  const std::string& admin = pgAdminUri();
  return admin.substr(0, admin.rfind('/') + 1) + name;
}

bool pgAdminExec(const std::string& sql) {
  std::unique_ptr<PGconn, decltype(&PQfinish)> c(PQconnectdb(pgAdminUri().c_str()), &PQfinish);
  if (PQstatus(c.get()) != CONNECTION_OK) {
    ADD_FAILURE() << "no test PostgreSQL: " << PQerrorMessage(c.get());
    return false;
  }
  std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(c.get(), sql.c_str()), &PQclear);
  const auto st = PQresultStatus(r.get());
  if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
    ADD_FAILURE() << sql << ": " << PQresultErrorMessage(r.get());
    return false;
  }
  return true;
}

std::string pgCreateDatabase() {
  static std::atomic<int> n{0};
  const std::string name = "t" + std::to_string(::getpid()) + "_" + std::to_string(++n);
  pgAdminExec("CREATE DATABASE " + name);
  return pgUriOf(name);
}

} // namespace tellus::test
