#include "WriteQueue.hpp"

namespace tellus::detail {

namespace {

constexpr std::size_t kMaxBatch = 1024;
constexpr std::size_t kMaxChangedRows = 4096; // beyond: every remembered row is forgotten
constexpr std::size_t kMaxTouches = 65536;    // beyond: access times are written at once

} // namespace

WriteQueue::WriteQueue(
    ITileIndex& index, ITileStore& store, RowCache& rows, const Clock& clock, Settings s)
    : index_(index), store_(store), rows_(rows), clock_(clock), settings_(s) {}

WriteQueue::~WriteQueue() {
  stop();
}

void WriteQueue::start() {
  writer_ = std::thread([this] { writerLoop(); });
}

void WriteQueue::stop() {
  if (!writer_.joinable()) return;
  {
    std::lock_guard lock(queueMutex_);
    stopping_ = true;
  }
  queueCv_.notify_all();
  writer_.join();
}

WriteQueue::Result WriteQueue::submit(Apply apply, After after, bool ownTransactions) {
  auto refuse = [&](CacheError e) -> Result {
    Result r = std::unexpected(std::move(e));
    if (after) after(r);
    return r;
  };
  if (settings_.readOnly) return refuse(CacheError{CacheErrc::ReadOnly, "the cache is read-only"});
  auto op = std::make_unique<Op>();
  op->apply = std::move(apply);
  op->after = std::move(after);
  op->ownTransactions = ownTransactions;
  auto fut = op->done.get_future();
  {
    std::lock_guard lock(queueMutex_);
    if (stopping_) {
      after = std::move(op->after);
      return refuse(CacheError{CacheErrc::Io, "the cache is closing"});
    }
    queue_.push_back(std::move(op));
  }
  if (writeMutex_.try_lock()) {
    // The index is free: commit the queue (ours included) on this thread.
    drainLocked();
    writeMutex_.unlock();
  } else {
    queueCv_.notify_one(); // whoever holds it, or the writer thread after it, takes ours too
  }
  return fut.get();
}

void WriteQueue::submitDetached(Apply apply, After after) {
  auto op = std::make_unique<Op>();
  op->apply = std::move(apply);
  op->after = std::move(after);
  {
    std::lock_guard lock(queueMutex_);
    if (!stopping_ && !settings_.readOnly) {
      queue_.push_back(std::move(op));
      op = nullptr;
    }
  }
  if (op) {
    if (op->after) op->after(std::unexpected(CacheError{CacheErrc::Io, "the cache is closing"}));
    return;
  }
  queueCv_.notify_one();
}

void WriteQueue::recordTouch(const RowKey& key, UnixMillis when) {
  std::lock_guard lock(queueMutex_);
  touches_[key] = when;
}

void WriteQueue::flush() {
  if (settings_.readOnly) return;
  // An operation that writes the pending last-access times, then wait for the queue to drain.
  (void)submit([this]() -> Result {
    Touches batch;
    {
      std::lock_guard lock(queueMutex_);
      batch.swap(touches_);
    }
    for (const auto& [rk, when] : batch)
      index_.touch(rk.dataset, rk.key, when);
    return {};
  });
  waitIdle();
}

// ---------------------------------------------------------------------------------- row changes

void WriteQueue::rowChanged(DatasetId id, const TileKey& key) {
  if (changedRows_.size() < kMaxChangedRows)
    changedRows_.push_back(RowKey{id, key});
  else
    allRowsChanged_ = true;
}

void WriteQueue::publishRowChanges() {
  if (allRowsChanged_) {
    rows_.clear();
  } else {
    for (const auto& k : changedRows_)
      rows_.invalidate(k);
  }
  changedRows_.clear();
  allRowsChanged_ = false;
}

std::expected<ChangesLock, CacheError> WriteQueue::lockChanges() {
  if (auto r = store_.lockChanges(settings_.busyTimeout); !r) return std::unexpected(r.error());
  return ChangesLock{&store_};
}

// ---------------------------------------------------------------------------------- batches

void WriteQueue::runBatch(std::vector<std::unique_ptr<Op>>& ops) {
  std::vector<Result> results(ops.size());
  std::vector<bool> finished(ops.size(), false);
  auto finish = [&](std::size_t i, const Result& outcome) {
    if (ops[i]->after) ops[i]->after(outcome);
    finished[i] = true;
  };
  auto failAll = [&](const CacheError& e) {
    const Result r = std::unexpected(e);
    for (std::size_t i = ops.size(); i-- > 0;)
      finish(i, r);
    for (auto& op : ops)
      op->done.set_value(r);
  };
  auto changesLock = lockChanges();
  if (!changesLock) return failAll(changesLock.error());
  auto started = index_.begin();
  if (!started) return failAll(started.error());
  if (ops.size() == 1) {
    // Alone in its transaction: a failure rolls the whole (one-operation) batch back.
    results[0] = ops[0]->apply();
    if (!results[0]) {
      index_.rollback();
      publishRowChanges();
      finish(0, results[0]);
      ops[0]->done.set_value(std::move(results[0]));
      return;
    }
  } else {
    // A savepoint per operation: one failure does not sink the batch.
    for (std::size_t i = 0; i < ops.size(); ++i) {
      index_.savepoint();
      results[i] = ops[i]->apply();
      if (!results[i]) {
        index_.rollbackToSavepoint();
        finish(i, results[i]);
      }
      index_.releaseSavepoint();
    }
  }
  const auto committed = index_.commit();
  publishRowChanges(); // before anyone is told: a put is visible to the next get
  for (std::size_t i = ops.size(); i-- > 0;) {
    if (finished[i]) continue;
    finish(i, committed ? results[i] : Result(std::unexpected(committed.error())));
  }
  for (std::size_t i = 0; i < ops.size(); ++i)
    ops[i]->done.set_value(!committed && results[i] ? Result(std::unexpected(committed.error()))
                                                    : results[i]);
}

void WriteQueue::runAlone(Op& op) {
  auto r = op.apply();
  publishRowChanges();
  if (op.after) op.after(r);
  op.done.set_value(std::move(r));
}

/** Runs queued operations until the queue is empty. Requires the writer lock. */
void WriteQueue::drainLocked() {
  for (;;) {
    std::vector<std::unique_ptr<Op>> ops;
    {
      std::lock_guard lock(queueMutex_);
      while (!queue_.empty() && ops.size() < kMaxBatch) {
        ops.push_back(std::move(queue_.front()));
        queue_.pop_front();
      }
      if (ops.empty()) return;
      ++busy_;
    }
    std::vector<std::unique_ptr<Op>> group;
    for (auto& op : ops) {
      if (!op->ownTransactions) {
        group.push_back(std::move(op));
        continue;
      }
      if (!group.empty()) runBatch(group);
      group.clear();
      runAlone(*op);
    }
    if (!group.empty()) runBatch(group);
    {
      std::lock_guard lock(queueMutex_);
      --busy_;
      evictDue_ = evictDue_ || settings_.evictAfterWrites;
    }
    idleCv_.notify_all();
    if (settings_.evictAfterWrites) queueCv_.notify_one(); // eviction runs on the writer thread
  }
}

void WriteQueue::flushTouches(Touches& batch) {
  if (batch.empty()) return;
  if (!index_.begin()) return; // last-access times are advisory: a failure only delays them
  for (const auto& [rk, when] : batch)
    index_.touch(rk.dataset, rk.key, when);
  (void)index_.commit();
  batch.clear();
}

void WriteQueue::writerLoop() {
  auto lastTouchFlush = clock_.steady();
  for (;;) {
    Touches touchBatch;
    bool stop = false;
    bool evict = false;
    {
      std::unique_lock lock(queueMutex_);
      // A real wait (a wake-up, not a measurement): the clock decides below whether it is time.
      queueCv_.wait_for(lock, settings_.accessFlushInterval, [this] {
        return stopping_ || !queue_.empty() || evictDue_;
      });
      const auto now = clock_.steady();
      if (stopping_ || now - lastTouchFlush >= settings_.accessFlushInterval ||
          touches_.size() > kMaxTouches) {
        touchBatch.swap(touches_);
        lastTouchFlush = now;
      }
      stop = stopping_;
      evict = std::exchange(evictDue_, false);
      ++busy_;
    }
    {
      std::lock_guard w(writeMutex_);
      flushTouches(touchBatch);
      drainLocked();
      if (evict && evict_) evict_();
    }
    {
      std::lock_guard lock(queueMutex_);
      --busy_;
      if (stop && queue_.empty()) {
        idleCv_.notify_all();
        return;
      }
    }
    idleCv_.notify_all();
  }
}

void WriteQueue::waitIdle() {
  std::unique_lock lock(queueMutex_);
  idleCv_.wait(lock, [this] { return queue_.empty() && busy_ == 0 && !evictDue_; });
}

} // namespace tellus::detail
