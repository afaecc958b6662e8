#pragma once
// The PostgreSQL server of tellus_cache_pg_tests: started once per ctest run by a fixture
// (tests/CMakeLists.txt: tests/support/postgres.sh start, its URI in $TELLUS_TEST_PG_URI_FILE), or,
// when the executable runs alone, once per process here. Each test gets databases of its own.

#include <string>

namespace tellus::test {

/** The server's URI (the `postgres` database, the superuser `tellus`, trust on loopback). */
const std::string& pgAdminUri();

/** Creates a fresh database and returns its URI. */
std::string pgCreateDatabase();

/** The URI of database `name` on the test server. */
std::string pgUriOf(const std::string& name);

/** Runs SQL on the admin database; false (and a test failure) when it fails. */
bool pgAdminExec(const std::string& sql);

} // namespace tellus::test
