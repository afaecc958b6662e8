#pragma once
/**
 * @file WriteQueue.hpp
 * @brief The cache's one writer per process: operations are queued and committed in batches
 * (group commit) by whoever holds the writer lock: the caller of submit() itself when the index is
 * free (no thread hand-off on the common, uncontended path), else the writer thread, which also
 * writes access times and runs eviction.
 *
 * A batch is one index transaction under the store's changes lock. Operations change tiles in
 * their `apply` (a put installs its staged tile, a removal hides the tile), in order, and their
 * `after` keeps or undoes that with the outcome: an operation that fails is undone at once, before
 * the next one runs (its savepoint is rolled back); when the commit fails, every one is undone, the
 * last first. Rows an operation changed (rowChanged) are forgotten by the row cache after the
 * commit and before anyone is told, so this process reads its own writes.
 *
 * Lock order: the writer lock, then the store's changes lock, then the index's write lock.
 */

#include "RowCache.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileIndex.hpp>
#include <tellus/cache/TileStore.hpp>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

namespace tellus::detail {

/** The store's changes lock, released when this goes. */
class ChangesLock {
public:
  ChangesLock() = default;
  explicit ChangesLock(ITileStore* store) : store_(store) {}
  ChangesLock(ChangesLock&& o) noexcept : store_(std::exchange(o.store_, nullptr)) {}
  ChangesLock& operator=(ChangesLock&&) = delete;
  ~ChangesLock() {
    if (store_) store_->unlockChanges();
  }

private:
  ITileStore* store_ = nullptr;
};

class WriteQueue {
public:
  using Result = std::expected<void, CacheError>;
  /** Runs inside the batch's transaction, under the writer lock. */
  using Apply = std::function<Result()>;
  /** Runs after the commit or rollback (tile clean-up), with the operation's outcome. */
  using After = std::function<void(const Result& outcome)>;

  struct Settings {
    bool readOnly = false;
    bool evictAfterWrites = false; ///< a size limit is set: run `evict` after each drain
    std::chrono::milliseconds accessFlushInterval{1000};
    std::chrono::milliseconds busyTimeout{60000}; ///< waiting for another process's lock
  };

  WriteQueue(ITileIndex& index, ITileStore& store, RowCache& rows, const Clock& clock, Settings s);
  ~WriteQueue();
  WriteQueue(const WriteQueue&) = delete;
  WriteQueue& operator=(const WriteQueue&) = delete;

  /** What runs on the writer thread after writes when Settings::evictAfterWrites. */
  void setEviction(std::function<void()> evict) { evict_ = std::move(evict); }
  void start();
  /** Commits what is queued and stops the writer thread. */
  void stop();

  /** Queues an operation and waits for its commit. `after` runs in every case, with the outcome.
   * `ownTransactions`: the operation runs alone and begins and commits its own transactions
   * (prune, eviction, rebuild). */
  Result submit(Apply apply, After after = {}, bool ownTransactions = false);
  /** Queues without waiting (self-healing clean-ups from readers, write-behind puts). */
  void submitDetached(Apply apply, After after = {});
  /** Remembers a last access; the writer writes it with the next flush of access times. */
  void recordTouch(const RowKey& key, UnixMillis when);
  /** Writes pending access times and waits until every queued write is committed. */
  void flush();

  // --- under the writer lock only (inside operations) -------------------------------------------
  void rowChanged(DatasetId id, const TileKey& key);
  void allRowsChanged() { allRowsChanged_ = true; }
  /** After a commit (or rollback): the row cache forgets what changed. */
  void publishRowChanges();
  /** Takes the store's changes lock (waiting at most busyTimeout for another process). */
  std::expected<ChangesLock, CacheError> lockChanges();

  /** The writer lock if it is free now (looking at the index between writes); else not owned. */
  std::unique_lock<std::mutex> tryLock() { return std::unique_lock(writeMutex_, std::try_to_lock); }

private:
  struct Op {
    Apply apply;
    After after;
    bool ownTransactions = false;
    std::promise<Result> done;
  };
  using Touches = std::unordered_map<RowKey, UnixMillis, RowKeyHash>;

  void runBatch(std::vector<std::unique_ptr<Op>>& ops);
  void runAlone(Op& op);
  void drainLocked();
  void writerLoop();
  void flushTouches(Touches& batch);
  void waitIdle();

  ITileIndex& index_;
  ITileStore& store_;
  RowCache& rows_;
  const Clock& clock_;
  Settings settings_;
  std::function<void()> evict_;

  std::mutex queueMutex_;
  std::condition_variable queueCv_;
  std::condition_variable idleCv_;
  std::deque<std::unique_ptr<Op>> queue_; // guarded by queueMutex_
  int busy_ = 0;                          // batches being run (guarded by queueMutex_)
  bool stopping_ = false;                 // guarded by queueMutex_
  bool evictDue_ = false;                 // guarded by queueMutex_
  Touches touches_;                       // guarded by queueMutex_
  std::thread writer_;

  std::mutex writeMutex_; // the writer lock: owns the index's write side and what follows
  // Rows changed since the last commit (under writeMutex_).
  std::vector<RowKey> changedRows_;
  bool allRowsChanged_ = false;
};

} // namespace tellus::detail
