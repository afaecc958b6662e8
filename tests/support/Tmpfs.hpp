#pragma once
// A real full disk for fault tests: a test body runs in a child process that sees a small tmpfs
// (a byte size and an inode count) mounted on a directory, in its own mount namespace.
//
// The child first enters a user namespace with a mount namespace (unshare(CLONE_NEWUSER |
// CLONE_NEWNS), as `unshare -rm` does: works unprivileged where user namespaces are allowed);
// failing that, a plain mount namespace (needs root). When neither can mount, the test is skipped
// with the reason (TELLUS_ON_TMPFS). The mount disappears with the child.
//
// The body runs in the child: GoogleTest assertions work there (their failures print from the
// child and make it exit 1); the child must not return into the test framework, so the body is
// followed by _exit.

#include <gtest/gtest.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <sched.h>
#include <string>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

namespace tellus::test {

inline constexpr int kTmpfsUnavailable = 77;

namespace detail {

inline bool writeProcFile(const char* path, const std::string& text) {
  const int fd = ::open(path, O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  return ok;
}

/** In the child: enter the namespaces and mount; "" on success, else why not. */
inline std::string mountTmpfs(bool userNamespace,
                              const std::filesystem::path& dir,
                              std::size_t sizeBytes,
                              std::size_t inodes) {
  const uid_t uid = ::getuid();
  const gid_t gid = ::getgid();
  if (userNamespace) {
    if (::unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0)
      return std::string("unshare(CLONE_NEWUSER | CLONE_NEWNS): ") + std::strerror(errno);
    (void)writeProcFile("/proc/self/setgroups", "deny");
    if (!writeProcFile("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
        !writeProcFile("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1"))
      return std::string("writing the uid/gid map: ") + std::strerror(errno);
  } else if (::unshare(CLONE_NEWNS) != 0) {
    return std::string("unshare(CLONE_NEWNS): ") + std::strerror(errno);
  }
  // Nothing mounted here may reach the parent's namespace.
  (void)::mount("none", "/", nullptr, MS_REC | MS_PRIVATE, nullptr);
  const std::string options =
      "size=" + std::to_string(sizeBytes) + ",nr_inodes=" + std::to_string(inodes) + ",mode=0755";
  if (::mount("tmpfs", dir.c_str(), "tmpfs", MS_NOSUID | MS_NODEV, options.c_str()) != 0)
    return std::string("mount -t tmpfs: ") + std::strerror(errno);
  return {};
}

} // namespace detail

/**
 * Runs body() in a child that sees a tmpfs of `sizeBytes` bytes and `inodes` inodes on `dir`.
 * Returns the child's exit code (0: the body's assertions held), or kTmpfsUnavailable with `why`
 * set when no mount was possible.
 */
template <class Body>
int runOnTmpfs(const std::filesystem::path& dir,
               std::size_t sizeBytes,
               std::size_t inodes,
               std::string& why,
               Body body) {
  std::string reasons;
  for (const bool userNamespace : {true, false}) {
    int pipeFds[2];
    if (::pipe2(pipeFds, O_CLOEXEC) != 0) {
      why = "pipe2 failed";
      return kTmpfsUnavailable;
    }
    std::fflush(stdout);
    std::fflush(stderr);
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(pipeFds[0]);
      const std::string err = detail::mountTmpfs(userNamespace, dir, sizeBytes, inodes);
      if (!err.empty()) {
        (void)!::write(pipeFds[1], err.data(), err.size());
        ::_exit(kTmpfsUnavailable);
      }
      ::close(pipeFds[1]);
      body();
      std::fflush(stdout);
      std::fflush(stderr);
      ::_exit(::testing::Test::HasFailure() ? 1 : 0);
    }
    ::close(pipeFds[1]);
    std::string message;
    char buf[256];
    for (ssize_t n; (n = ::read(pipeFds[0], buf, sizeof buf)) > 0;)
      message.append(buf, static_cast<std::size_t>(n));
    ::close(pipeFds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (code != kTmpfsUnavailable || message.empty()) return code;
    reasons += (reasons.empty() ? "" : "; ") + message;
  }
  why = "no tmpfs could be mounted for this fault test (" + reasons + ")";
  return kTmpfsUnavailable;
}

/** Fills the file system under `dir` with one file until nothing more fits; returns its path. */
inline std::filesystem::path fillDisk(const std::filesystem::path& dir) {
  const auto path = dir / "filler";
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  EXPECT_GE(fd, 0) << "cannot create " << path;
  if (fd < 0) return path;
  const std::string block(4096, 'f');
  while (::write(fd, block.data(), block.size()) > 0) {
  }
  // The last partial page, byte by byte.
  while (::write(fd, "f", 1) > 0) {
  }
  ::close(fd);
  return path;
}

/** Uses up every free inode under `dir` with empty files; returns how many it made. */
inline int useUpInodes(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir / "inodes");
  int n = 0;
  for (;; ++n) {
    const auto p = dir / "inodes" / std::to_string(n);
    const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) break;
    ::close(fd);
  }
  return n;
}

} // namespace tellus::test

/** Runs the body (a lambda) on a tmpfs in a child (see runOnTmpfs); skips the test with the reason
 * when no tmpfs can be mounted, and fails it when the child's assertions failed. */
#define TELLUS_ON_TMPFS(dir, sizeBytes, inodes, ...)                                               \
  do {                                                                                             \
    std::string tellusTmpfsWhy;                                                                    \
    const int tellusTmpfsCode =                                                                    \
        ::tellus::test::runOnTmpfs((dir), (sizeBytes), (inodes), tellusTmpfsWhy, __VA_ARGS__);     \
    if (tellusTmpfsCode == ::tellus::test::kTmpfsUnavailable && !tellusTmpfsWhy.empty())           \
      GTEST_SKIP() << tellusTmpfsWhy;                                                              \
    EXPECT_EQ(tellusTmpfsCode, 0)                                                                  \
        << "the test's child on the tmpfs failed (see its output above)";                          \
  } while (false)
