#include "FileIo.hpp"

#include <tellus/cache/TileFile.hpp>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

namespace tellus::fileio {

namespace {

std::atomic<std::uint64_t> gTempCounter{0};

CacheError errnoError(int err, const std::string& what, const std::filesystem::path& path) {
  const bool full = err == ENOSPC || err == EFBIG || err == EDQUOT;
  return CacheError{full ? CacheErrc::DiskFull : CacheErrc::Io,
                    what + " " + path.string() + ": " + std::strerror(err)};
}

} // namespace

void ignoreFileSizeSignal() {
  static std::once_flag once;
  std::call_once(once, [] { std::signal(SIGXFSZ, SIG_IGN); });
}

bool isTempName(const std::string& name) {
  return name.size() > 5 && name.front() == '.' && name.ends_with(".tmp");
}

std::expected<void, CacheError> writeFileAtomic(const std::filesystem::path& target,
                                                std::span<const std::byte> bytes,
                                                bool fsyncFile) {
  // Built with append: g++ 12 reports a false -Wrestrict on `"." + std::string`.
  std::string name(1, '.');
  name.append(target.filename().native());
  name.append(1, '.').append(std::to_string(::getpid()));
  name.append(1, '.').append(std::to_string(gTempCounter.fetch_add(1)));
  name.append(".tmp");
  const std::filesystem::path temp = target.parent_path() / name;
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return std::unexpected(errnoError(errno, "cannot create", temp));
  auto failWith = [&](int err, const char* what) -> std::expected<void, CacheError> {
    ::close(fd);
    ::unlink(temp.c_str());
    return std::unexpected(errnoError(err, what, target));
  };
  const auto* p = reinterpret_cast<const char*>(bytes.data());
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return failWith(errno, "cannot write");
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (fsyncFile && ::fsync(fd) != 0) return failWith(errno, "cannot fsync");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return std::unexpected(errnoError(err, "cannot close", target));
  }
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
