#include "Pg.hpp"

#include <tellus/cache_pg/PgTileLeases.hpp>

#include <atomic>
#include <map>
#include <mutex>
#include <poll.h>
#include <set>
#include <sys/eventfd.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace tellus {

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kChannel = "tellus_tiles";

class PgTileLeases final : public ITileLeases {
public:
  explicit PgTileLeases(PgConnectOptions options) : options_(std::move(options)) {}

  ~PgTileLeases() override {
    stop_ = true;
    const std::uint64_t one = 1;
    (void)::write(wake_, &one, sizeof one);
    if (listener_.joinable()) listener_.join();
    ::close(wake_);
  }

  std::expected<void, CacheError> start() {
    wake_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    auto c = pg::connect(options_);
    if (!c) return std::unexpected(c.error());
    lockConn_ = std::move(*c);
    auto l = listen();
    if (!l) return l;
    listener_ = std::thread([this] { run(); });
    return {};
  }

  LeaseOutcome acquireOrWait(const LeaseKey& key,
                             std::chrono::milliseconds recheck,
                             std::function<void()> retry) override {
    const std::int64_t n = leaseNumber(key);
    // Registered first: a release heard from now on wakes it. Whoever claims it first, the
    // listener (calling retry) or this call (taking the lease), decides which happens.
    auto claimed = std::make_shared<std::atomic<bool>>(false);
    addWaiter(n, Clock::now() + recheck, std::move(retry), claimed);
    std::lock_guard lock(lockMutex_);
    if (held_.contains(n)) { // this process holds it (session locks nest): wait like the others
      wakeListener();
      return LeaseOutcome::Waiting;
    }
    pg::Params p;
    p.add(n);
    std::expected<pg::ResultPtr, CacheError> r = std::unexpected(CacheError{});
    if (ensureLockConn() && listening_)
      r = pg::exec(lockConn_.get(), "SELECT pg_try_advisory_lock($1)", p, "taking a lease");
    const bool taken = r && pg::text(r->get(), 0, 0) == "t";
    if (!r || taken) {
      if (claimed->exchange(true)) {
        // The listener called retry already: that call goes on; this one gives the lock back.
        if (taken)
          (void)pg::exec(lockConn_.get(), "SELECT pg_advisory_unlock($1)", p, "giving back");
        return LeaseOutcome::Waiting;
      }
      if (!r) return LeaseOutcome::Unavailable;
      held_.insert(n);
      return LeaseOutcome::Acquired;
    }
    wakeListener(); // its next deadline may be this one
    return LeaseOutcome::Waiting;
  }

  void release(const LeaseKey& key) override {
    const std::int64_t n = leaseNumber(key);
    pg::Params p;
    p.add(n).add(std::string_view(std::to_string(n)));
    std::lock_guard lock(lockMutex_);
    if (held_.erase(n) == 0) return;
    if (pg::broken(lockConn_.get())) return; // the session, and its locks, are gone already
    (void)pg::exec(lockConn_.get(),
                   "SELECT pg_advisory_unlock($1), pg_notify('tellus_tiles', $2)",
                   p,
                   "giving a lease back");
  }

  void progress(const LeaseKey& key) override {
    const std::int64_t n = leaseNumber(key);
    pg::Params p;
    p.add(std::string_view(std::to_string(n)));
    std::lock_guard lock(lockMutex_);
    if (!held_.contains(n) || pg::broken(lockConn_.get())) return;
    // The same NOTIFY as a release's: a waiter woken looks again, and waits again for the rest.
    (void)pg::exec(lockConn_.get(), "SELECT pg_notify('tellus_tiles', $1)", p, "announcing a tile");
  }

  bool healthy() const override { return listening_.load(); }

private:
  struct Waiter {
    std::uint64_t id;
    Clock::time_point deadline;
    std::function<void()> retry;
    std::shared_ptr<std::atomic<bool>> claimed; ///< set by whoever acts on it first
  };

  void addWaiter(std::int64_t n,
                 Clock::time_point deadline,
                 std::function<void()> f,
                 std::shared_ptr<std::atomic<bool>> claimed) {
    std::lock_guard lock(waitersMutex_);
    waiters_[n].push_back(Waiter{++nextId_, deadline, std::move(f), std::move(claimed)});
  }

  void wakeListener() {
    const std::uint64_t one = 1;
    (void)::write(wake_, &one, sizeof one);
  }

  /** Under lockMutex_. */
  bool ensureLockConn() {
    if (pg::broken(lockConn_.get())) {
      if (lockConn_) PQreset(lockConn_.get());
      if (!lockConn_ || pg::broken(lockConn_.get())) {
        auto c = pg::connect(options_);
        if (c) lockConn_ = std::move(*c);
      }
    }
    const bool ok = !pg::broken(lockConn_.get());
    lockHealthy_ = ok;
    return ok;
  }

  std::expected<void, CacheError> listen() {
    auto c = pg::connect(options_);
    if (!c) return std::unexpected(c.error());
    auto r = pg::exec(c->get(), "LISTEN tellus_tiles", "listening for leases");
    if (!r) return std::unexpected(r.error());
    listenConn_ = std::move(*c);
    listening_ = true;
    return {};
  }

  /** Takes the waiters due (all of `n`'s, or those past their deadline). */
  std::vector<std::function<void()>>
  due(const std::vector<std::int64_t>& released, Clock::time_point now, Clock::time_point* next) {
    std::vector<std::function<void()>> out;
    std::lock_guard lock(waitersMutex_);
    for (const std::int64_t n : released) {
      const auto it = waiters_.find(n);
      if (it == waiters_.end()) continue;
      for (auto& w : it->second)
        if (!w.claimed->exchange(true)) out.push_back(std::move(w.retry));
      waiters_.erase(it);
    }
    *next = now + std::chrono::seconds(1);
    for (auto it = waiters_.begin(); it != waiters_.end();) {
      auto& list = it->second;
      for (auto w = list.begin(); w != list.end();) {
        if (w->claimed->load()) { // taken by acquireOrWait
          w = list.erase(w);
        } else if (w->deadline <= now) {
          if (!w->claimed->exchange(true)) out.push_back(std::move(w->retry));
          w = list.erase(w);
        } else {
          *next = std::min(*next, w->deadline);
          ++w;
        }
      }
      it = list.empty() ? waiters_.erase(it) : std::next(it);
    }
    return out;
  }

  void run() {
    while (!stop_) {
      if (!listening_) {
        // The server went away: listen again (every 200 ms; waiters meanwhile wake by deadline).
        if (!listen()) {
          listenConn_.reset();
        }
      }
      std::vector<std::int64_t> released;
      if (listening_) {
        PGconn* c = listenConn_.get();
        if (!PQconsumeInput(c) || pg::broken(c)) {
          listening_ = false;
        } else {
          while (PGnotify* n = PQnotifies(c)) {
            released.push_back(std::stoll(n->extra));
            PQfreemem(n);
          }
        }
      }
      const auto now = Clock::now();
      Clock::time_point next;
      for (auto& f : due(released, now, &next))
        f();
      pollfd fds[2] = {{wake_, POLLIN, 0}, {-1, POLLIN, 0}};
      if (listening_) fds[1].fd = PQsocket(listenConn_.get());
      auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now());
      if (!listening_) wait = std::min(wait, std::chrono::milliseconds(200));
      (void)::poll(fds, 2, static_cast<int>(std::max<std::int64_t>(0, wait.count())));
      if (fds[0].revents & POLLIN) {
        std::uint64_t v = 0;
        (void)::read(wake_, &v, sizeof v);
      }
    }
  }

  PgConnectOptions options_;
  int wake_ = -1;
  std::atomic<bool> stop_{false};

  std::mutex lockMutex_;
  pg::ConnPtr lockConn_;
  std::atomic<bool> lockHealthy_{true};
  std::set<std::int64_t> held_; ///< leases this process holds (under lockMutex_)

  pg::ConnPtr listenConn_; // the listener thread's
  std::atomic<bool> listening_{false};
  std::thread listener_;

  std::mutex waitersMutex_;
  std::uint64_t nextId_ = 0;
  std::map<std::int64_t, std::vector<Waiter>> waiters_;
};

} // namespace

std::expected<std::shared_ptr<ITileLeases>, CacheError>
openPgTileLeases(const PgConnectOptions& options) {
  auto leases = std::make_shared<PgTileLeases>(options);
  if (auto s = leases->start(); !s) return std::unexpected(s.error());
  return leases;
}

} // namespace tellus
