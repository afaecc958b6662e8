#pragma once
/**
 * @file StoreGate.hpp
 * @brief Whether the cache stores what it is given: a put refused for lack of space (ENOSPC,
 * EDQUOT, EFBIG, SQLITE_FULL: CacheErrc::DiskFull) makes the cache refuse puts at once, touching
 * nothing, for `fullRecheck` (steady time of the injected clock), then try the store again. A put
 * that succeeds, or tiles removed, open it again. Counts refusals and write-behind drops
 * (StoreStatus). Lock-free.
 */

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileStore.hpp>

#include <atomic>
#include <chrono>
#include <expected>
#include <filesystem>
#include <string>

namespace tellus::detail {

class StoreGate {
public:
  using Result = std::expected<void, CacheError>;

  /** `root` names the cache in messages; `store` says what room is left. */
  StoreGate(std::filesystem::path root,
            const ITileStore& store,
            const Clock& clock,
            std::chrono::milliseconds fullRecheck)
      : root_(std::move(root)), store_(store), clock_(clock), fullRecheck_(fullRecheck) {}

  /** A DiskFull error that names the root and what is left in its store. */
  CacheError fullError(const std::string& detail) const {
    std::string msg = "the cache at " + root_.string() + " is full";
    if (const auto space = store_.freeSpace()) {
      msg += " (" + std::to_string(space->freeBytes) + " bytes and " +
             std::to_string(space->freeInodes) + " inodes free)";
    }
    msg += ": " + detail;
    return CacheError{CacheErrc::DiskFull, std::move(msg)};
  }

  /** A write refused for lack of space: refuse puts at once until fullRecheck has passed. */
  void noteFull() {
    fullUntilNs_.store(steadyNs() + std::chrono::nanoseconds(fullRecheck_).count(),
                       std::memory_order_relaxed);
    full_.store(true, std::memory_order_release);
  }
  /** A tile stored or removed: there is room (again). */
  void noteRoom() { full_.store(false, std::memory_order_release); }

  /** Whether a refusal for lack of space is recent (fullRecheck has not passed). */
  bool refusingNow() const {
    return full_.load(std::memory_order_acquire) &&
           steadyNs() < fullUntilNs_.load(std::memory_order_relaxed);
  }

  /** DiskFull at once while a refusal is recent (nothing touches the store). */
  Result refuseWhileFull() {
    if (!refusingNow()) return {};
    refused_.fetch_add(1, std::memory_order_relaxed);
    return std::unexpected(fullError("a write was refused for lack of space less than " +
                                     std::to_string(fullRecheck_.count()) +
                                     " ms ago; nothing was written"));
  }

  /** The outcome of a put as the caller sees it: a refusal for lack of space is counted,
   * remembered and worded with the root and its free space. */
  Result putOutcome(Result r) {
    if (r) {
      noteRoom();
      return r;
    }
    if (r.error().code != CacheErrc::DiskFull) return r;
    noteFull();
    refused_.fetch_add(1, std::memory_order_relaxed);
    return std::unexpected(fullError(r.error().message));
  }

  /** The outcome of a write-behind put, which nobody waits for: counted, not returned. */
  void writeBehindOutcome(const Result& r) {
    if (r) {
      noteRoom();
      return;
    }
    dropped_.fetch_add(1, std::memory_order_relaxed);
    if (r.error().code == CacheErrc::DiskFull) {
      noteFull();
      refused_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  StoreStatus status() const noexcept {
    StoreStatus s;
    s.writable = !full_.load(std::memory_order_acquire);
    s.refused = refused_.load(std::memory_order_relaxed);
    s.dropped = dropped_.load(std::memory_order_relaxed);
    return s;
  }

private:
  std::int64_t steadyNs() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(clock_.steady().time_since_epoch())
        .count();
  }

  std::filesystem::path root_;
  const ITileStore& store_;
  const Clock& clock_;
  std::chrono::milliseconds fullRecheck_;
  std::atomic<bool> full_{false};
  std::atomic<std::int64_t> fullUntilNs_{0};
  std::atomic<std::uint64_t> refused_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

} // namespace tellus::detail
