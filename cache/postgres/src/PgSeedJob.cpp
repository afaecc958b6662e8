#include "Pg.hpp"

#include <tellus/cache_pg/PgSeedJob.hpp>

namespace tellus {

struct PgSeedJob::Impl {
  pg::ConnPtr conn;
  std::string name;
  std::optional<SeedBand> held; ///< taken in the open transaction
};

PgSeedJob::PgSeedJob(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

PgSeedJob::~PgSeedJob() {
  if (impl_ && impl_->held) (void)pg::exec(impl_->conn.get(), "ROLLBACK", "giving a band back");
}

std::expected<std::unique_ptr<PgSeedJob>, CacheError> PgSeedJob::open(
    const PgConnectOptions& connect, std::string name, const std::vector<SeedBand>& bands) {
  auto c = pg::connect(connect);
  if (!c) return std::unexpected(c.error());
  auto impl = std::make_unique<Impl>();
  impl->conn = std::move(*c);
  impl->name = std::move(name);
  PGconn* db = impl->conn.get();
  // The bands as two arrays: one statement, however many there are.
  std::string levels = "{", rows = "{";
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (i) {
      levels += ',';
      rows += ',';
    }
    levels += std::to_string(bands[i].level);
    rows += std::to_string(bands[i].row);
  }
  levels += '}';
  rows += '}';
  pg::Params p;
  p.add(std::string_view(impl->name)).add(std::string_view(levels)).add(std::string_view(rows));
  if (auto ins = pg::exec(db,
                          "INSERT INTO seed_bands(job, level, row) SELECT $1, l, r FROM "
                          "unnest($2::integer[], $3::bigint[]) AS b(l, r) ON CONFLICT DO NOTHING",
                          p,
                          "adding the seed job's bands");
      !ins)
    return std::unexpected(ins.error());
  return std::unique_ptr<PgSeedJob>(new PgSeedJob(std::move(impl)));
}

std::expected<std::optional<SeedBand>, CacheError> PgSeedJob::next() {
  PGconn* db = impl_->conn.get();
  pg::Params job;
  job.add(std::string_view(impl_->name));
  if (impl_->held) {
    pg::Params p;
    p.add(std::string_view(impl_->name))
        .add(std::int64_t{impl_->held->level})
        .add(impl_->held->row);
    auto d =
        pg::exec(db,
                 "UPDATE seed_bands SET done = true WHERE job = $1 AND level = $2 AND row = $3",
                 p,
                 "finishing a band");
    impl_->held.reset();
    if (!d) {
      (void)pg::exec(db, "ROLLBACK", "giving a band back");
      return std::unexpected(d.error());
    }
    if (auto c = pg::exec(db, "COMMIT", "finishing a band"); !c) return std::unexpected(c.error());
  }
  if (auto b = pg::exec(db, "BEGIN", "taking a band"); !b) return std::unexpected(b.error());
  auto r = pg::exec(db,
                    "SELECT level, row FROM seed_bands WHERE job = $1 AND NOT done "
                    "ORDER BY level, row LIMIT 1 FOR UPDATE SKIP LOCKED",
                    job,
                    "taking a band");
  if (!r) {
    (void)pg::exec(db, "ROLLBACK", "taking a band");
    return std::unexpected(r.error());
  }
  if (PQntuples(r->get()) == 1) {
    impl_->held =
        SeedBand{static_cast<std::int32_t>(pg::i64(r->get(), 0, 0)), pg::i64(r->get(), 0, 1)};
    return impl_->held;
  }
  // None free. When none is held by another seeder either, the job is over: forget it.
  auto left = pg::exec(
      db, "SELECT count(*) FROM seed_bands WHERE job = $1 AND NOT done", job, "finishing the job");
  if (left && pg::i64(left->get(), 0, 0) == 0)
    (void)pg::exec(db, "DELETE FROM seed_bands WHERE job = $1", job, "finishing the job");
  if (auto c = pg::exec(db, "COMMIT", "finishing the job"); !c) return std::unexpected(c.error());
  return std::nullopt;
}

} // namespace tellus
