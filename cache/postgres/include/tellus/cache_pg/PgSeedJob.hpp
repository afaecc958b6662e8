#pragma once
/**
 * @file PgSeedJob.hpp
 * @brief One seeding job shared by several `tellus seed` on several machines (issue 27): the job's
 * bands (a level and a row of tiles) are rows of `seed_bands`, and each seeder takes the next band
 * no other holds with `SELECT ... FOR UPDATE SKIP LOCKED`, inside a transaction it keeps open while
 * it seeds the band. A seeder that dies gives its band back with its transaction; one that finishes
 * marks it done and commits. Every seeder inserts the whole job first (ON CONFLICT DO NOTHING), so
 * they may start in any order; the last one out forgets the job's finished bands, so the same
 * command run again seeds again (skipping what the index holds).
 */

#include <tellus/cache_pg/PgTileIndex.hpp>

#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

struct SeedBand {
  std::int32_t level = 0;
  std::int64_t row = 0;
  bool operator==(const SeedBand&) const = default;
};

class PgSeedJob {
public:
  /** Joins job `name` (any text naming the layer, time, levels and box), adding its bands. The
   * index's schema (openPgTileIndex) must exist: it holds the table. */
  static std::expected<std::unique_ptr<PgSeedJob>, CacheError>
  open(const PgConnectOptions& connect, std::string name, const std::vector<SeedBand>& bands);
  ~PgSeedJob();
  PgSeedJob(const PgSeedJob&) = delete;
  PgSeedJob& operator=(const PgSeedJob&) = delete;

  /** Marks the band taken last as done, then takes the next free one; nullopt: none is left. */
  std::expected<std::optional<SeedBand>, CacheError> next();

private:
  struct Impl;
  explicit PgSeedJob(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace tellus
