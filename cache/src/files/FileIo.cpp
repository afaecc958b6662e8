#include "FileIo.hpp"

#include <tellus/cache/TileFile.hpp>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <string>
#include <string_view>
#include <sys/stat.h>
#include <unistd.h>

namespace tellus::fileio {

namespace {

std::atomic<std::uint64_t> gTempCounter{0};

/** A process's start time (field 22 of /proc/<pid>/stat, clock ticks since boot); 0 if unknown. */
std::uint64_t processStartTime(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/stat";
  std::FILE* f = std::fopen(path.c_str(), "re");
  if (!f) return 0;
  char buf[1024];
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  const std::string_view text(buf, n);
  // The command name (field 2) is in parentheses and may hold spaces: count from after it.
  std::size_t pos = text.rfind(')');
  if (pos == std::string_view::npos) return 0;
  ++pos;
  for (int field = 3; field <= 22; ++field) {
    while (pos < text.size() && text[pos] == ' ')
      ++pos;
    const std::size_t end = std::min(text.find(' ', pos), text.size());
    if (field == 22) {
      std::uint64_t v = 0;
      const auto [p, ec] = std::from_chars(text.data() + pos, text.data() + end, v);
      return ec == std::errc{} ? v : 0;
    }
    pos = end;
  }
  return 0;
}

/** This process's start time, read once per process (a forked child reads its own). */
std::uint64_t ownStartTime() {
  static std::atomic<pid_t> cachedPid{0};
  static std::atomic<std::uint64_t> cachedStart{0};
  const pid_t pid = ::getpid();
  if (cachedPid.load(std::memory_order_acquire) == pid)
    return cachedStart.load(std::memory_order_relaxed);
  const std::uint64_t start = processStartTime(pid);
  cachedStart.store(start, std::memory_order_relaxed);
  cachedPid.store(pid, std::memory_order_release);
  return start;
}

template <class T> bool parseNumber(std::string_view s, T& out) {
  if (s.empty()) return false;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc{} && p == s.data() + s.size();
}

} // namespace

bool isNoSpace(int err) noexcept {
  return err == ENOSPC || err == EFBIG || err == EDQUOT;
}

CacheError errnoError(int err, const std::string& what, const std::filesystem::path& path) {
  return CacheError{isNoSpace(err) ? CacheErrc::DiskFull : CacheErrc::Io,
                    what + " " + path.string() + ": " + std::strerror(err)};
}

void ignoreFileSizeSignal() {
  static std::once_flag once;
  std::call_once(once, [] { std::signal(SIGXFSZ, SIG_IGN); });
}

std::string tempNameFor(const std::string& targetName) {
  // Built with append: g++ 12 reports a false -Wrestrict on `"." + std::string`.
  std::string name(1, '.');
  name.append(targetName);
  name.append(1, '.').append(std::to_string(::getpid()));
  name.append(1, '-').append(std::to_string(ownStartTime()));
  name.append(1, '.').append(std::to_string(gTempCounter.fetch_add(1)));
  name.append(".tmp");
  return name;
}

bool isTempName(const std::string& name) {
  return name.size() > 5 && name.front() == '.' && name.ends_with(".tmp");
}

bool tempOwnerAlive(const std::string& name) {
  if (!isTempName(name)) return true;
  const std::string_view body = std::string_view(name).substr(1, name.size() - 5);
  const auto lastDot = body.rfind('.');
  if (lastDot == std::string_view::npos || lastDot == 0) return true;
  std::uint64_t counter = 0;
  if (!parseNumber(body.substr(lastDot + 1), counter)) return true;
  const auto ownerDot = body.rfind('.', lastDot - 1);
  if (ownerDot == std::string_view::npos) return true;
  const std::string_view owner = body.substr(ownerDot + 1, lastDot - ownerDot - 1);
  const auto dash = owner.find('-');
  pid_t pid = 0;
  std::uint64_t start = 0;
  if (!parseNumber(owner.substr(0, dash), pid) || pid <= 0) return true;
  if (dash != std::string_view::npos && !parseNumber(owner.substr(dash + 1), start)) return true;
  if (start != 0) {
    const std::uint64_t actual = pid == ::getpid() ? ownStartTime() : processStartTime(pid);
    if (actual != 0) return actual == start; // the pid runs: the same process, or a reuse of it
  }
  if (pid == ::getpid()) return true;
  // No start time to compare (an older name, or no /proc): alive while the pid exists.
  return ::kill(pid, 0) == 0 || errno == EPERM;
}

namespace {

/** `temp` created exclusively and `bytes` written to it; its descriptor, open. On failure the
 * file is removed. */
std::expected<int, CacheError> writeOpen(const std::filesystem::path& temp,
                                         std::span<const std::byte> bytes,
                                         const std::filesystem::path& target,
                                         UnixMillis modified) {
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return std::unexpected(errnoError(errno, "cannot create a temp file for", target));
  const auto* p = reinterpret_cast<const char*>(bytes.data());
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(temp.c_str());
      return std::unexpected(errnoError(err, "cannot write", target));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (modified > 0) {
    const timespec times[2] = {
        {0, UTIME_OMIT},
        {static_cast<time_t>(modified / 1000), static_cast<long>(modified % 1000) * 1000000L}};
    if (::futimens(fd, times) != 0) {
      const int err = errno;
      ::close(fd);
      ::unlink(temp.c_str());
      return std::unexpected(errnoError(err, "cannot set the mtime of", target));
    }
  }
  return fd;
}

/** Optionally fsyncs and closes a file writeOpen wrote; on failure the file is removed. */
std::expected<void, CacheError> syncAndClose(int fd,
                                             bool fsyncFile,
                                             const std::filesystem::path& temp,
                                             const std::filesystem::path& target) {
  if (fsyncFile && ::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(temp.c_str());
    return std::unexpected(errnoError(err, "cannot fsync", target));
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return std::unexpected(errnoError(err, "cannot close", target));
  }
  return {};
}

} // namespace

UnixMillis modifiedMillis(const struct stat& st) noexcept {
  return static_cast<UnixMillis>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
}

std::expected<void, CacheError> writeTemp(const std::filesystem::path& temp,
                                          std::span<const std::byte> bytes,
                                          bool fsyncFile,
                                          const std::filesystem::path& target,
                                          UnixMillis modified) {
  const auto fd = writeOpen(temp, bytes, target, modified);
  if (!fd) return std::unexpected(fd.error());
  return syncAndClose(*fd, fsyncFile, temp, target);
}

std::expected<void, CacheError> writeTemps(std::span<const TempWrite> files, bool fsyncFiles) {
  std::vector<int> fds;
  fds.reserve(files.size());
  std::optional<CacheError> failed;
  for (const TempWrite& f : files) {
    auto fd = writeOpen(f.temp, f.bytes, f.target, f.modified);
    if (!fd) {
      failed = std::move(fd.error());
      break;
    }
    fds.push_back(*fd);
  }
  // Every file's write-back under way before the first fsync: the first one's journal commit then
  // carries the others' blocks too, and their fsyncs find little left to do. Its errors, if any,
  // come back from the fsync.
  if (fsyncFiles && !failed) {
    for (const int fd : fds)
      (void)::sync_file_range(fd, 0, 0, SYNC_FILE_RANGE_WRITE);
  }
  for (std::size_t i = 0; i < fds.size(); ++i) {
    auto done = syncAndClose(fds[i], fsyncFiles && !failed, files[i].temp, files[i].target);
    if (!done && !failed) failed = std::move(done.error());
  }
  if (!failed) return {};
  for (std::size_t i = 0; i < fds.size(); ++i)
    ::unlink(files[i].temp.c_str());
  return std::unexpected(std::move(*failed));
}

std::expected<void, CacheError> writeFileAtomic(const std::filesystem::path& target,
                                                std::span<const std::byte> bytes,
                                                bool fsyncFile) {
  const std::filesystem::path temp = target.parent_path() / tempNameFor(target.filename());
  if (auto w = writeTemp(temp, bytes, fsyncFile, target); !w) return w;
  if (::rename(temp.c_str(), target.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return std::unexpected(errnoError(err, "cannot rename into", target));
  }
  return {};
}

std::optional<std::vector<std::byte>> readFile(const std::filesystem::path& path,
                                               std::optional<std::size_t> expectedSize) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size < 0 ||
      (expectedSize && static_cast<std::size_t>(st.st_size) != *expectedSize)) {
    ::close(fd);
    return std::nullopt;
  }
  std::vector<std::byte> out(static_cast<std::size_t>(st.st_size));
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::read(fd, out.data() + done, out.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      return std::nullopt;
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return out;
}

} // namespace tellus::fileio

namespace tellus {

TileFile::~TileFile() {
  if (fd_ >= 0) ::close(fd_);
}

std::optional<std::vector<std::byte>> TileFile::readAll() const {
  if (size_ < 0) return std::nullopt;
  std::vector<std::byte> out(static_cast<std::size_t>(size_));
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return std::nullopt;
    done += static_cast<std::size_t>(n);
  }
  return out;
}

} // namespace tellus
