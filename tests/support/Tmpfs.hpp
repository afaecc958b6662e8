#pragma once
// A real full disk for fault tests: the test's body runs in a process that sees a small tmpfs (a
// byte size and an inode count) mounted on a directory, in its own mount namespace.
//
// A forked child first enters a user namespace with a mount namespace (unshare(CLONE_NEWUSER |
// CLONE_NEWNS), as `unshare -rm` does: works unprivileged where user namespaces are allowed);
// failing that, a plain mount namespace (needs root). It mounts the tmpfs and then executes this
// test executable again, for this one test (a fresh process: no threads inherited from the one
// that forked, which ThreadSanitizer could not follow), where the body runs on the mount. When no
// namespace can mount, the test is skipped with the reasons. The mount disappears with the child.

#include "TempDir.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <optional>
#include <sched.h>
#include <string>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

namespace tellus::test {

inline constexpr int kTmpfsUnavailable = 77;
inline constexpr const char* kTmpfsInsideEnv = "TELLUS_TEST_TMPFS_INSIDE"; // the mount, inside
inline constexpr const char* kTmpfsTestEnv = "TELLUS_TEST_TMPFS_TEST";     // the test it is for

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

inline std::string currentTestName() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return info ? std::string(info->test_suite_name()) + "." + info->name() : std::string();
}

} // namespace detail

/** The tmpfs this process runs on, when it is the re-executed test inside the namespace. */
inline std::optional<std::filesystem::path> insideTmpfs() {
  const char* inside = std::getenv(kTmpfsInsideEnv);
  const char* test = std::getenv(kTmpfsTestEnv);
  if (!inside || !test || detail::currentTestName() != test) return std::nullopt;
  return std::filesystem::path(inside);
}

/**
 * Mounts a tmpfs of `sizeBytes` bytes and `inodes` inodes on `dir` in a child's namespaces and runs
 * the current test again in it (see the file comment). Returns the inner run's exit code (0: its
 * assertions held), or kTmpfsUnavailable with `why` set when no mount was possible.
 */
inline int runTestOnTmpfs(const std::filesystem::path& dir,
                          std::size_t sizeBytes,
                          std::size_t inodes,
                          std::string& why) {
  const std::string test = detail::currentTestName();
  const std::string filter = "--gtest_filter=" + test;
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
      std::string err = detail::mountTmpfs(userNamespace, dir, sizeBytes, inodes);
      if (err.empty()) {
        ::setenv(kTmpfsInsideEnv, dir.c_str(), 1);
        ::setenv(kTmpfsTestEnv, test.c_str(), 1);
        char* const argv[] = {
            const_cast<char*>("tellus-test-on-tmpfs"), const_cast<char*>(filter.c_str()), nullptr};
        ::execv("/proc/self/exe", argv); // closes the pipe: the parent reads "" and waits
        err = std::string("exec /proc/self/exe: ") + std::strerror(errno);
      }
      (void)!::write(pipeFds[1], err.data(), err.size());
      ::_exit(kTmpfsUnavailable);
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
    if (message.empty()) return code;
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

} // namespace tellus::test

/**
 * Runs the body, a callable taking the mount's path, on a tmpfs of `sizeBytes` bytes and `inodes`
 * inodes: in the re-executed test inside the namespace it runs the body; in the test as ctest
 * starts it, it mounts and re-executes (runTestOnTmpfs), skips the test with the reasons when no
 * tmpfs can be mounted, and fails it when the inner run failed.
 */
#define TELLUS_ON_TMPFS(sizeBytes, inodes, ...)                                                    \
  do {                                                                                             \
    if (const auto tellusTmpfsInside = ::tellus::test::insideTmpfs()) {                            \
      (__VA_ARGS__)(*tellusTmpfsInside);                                                           \
      break;                                                                                       \
    }                                                                                              \
    ::tellus::test::TempDir tellusTmpfsDir("tmpfs");                                               \
    std::string tellusTmpfsWhy;                                                                    \
    const int tellusTmpfsCode = ::tellus::test::runTestOnTmpfs(                                    \
        tellusTmpfsDir.path(), (sizeBytes), (inodes), tellusTmpfsWhy);                             \
    if (tellusTmpfsCode == ::tellus::test::kTmpfsUnavailable && !tellusTmpfsWhy.empty())           \
      GTEST_SKIP() << tellusTmpfsWhy;                                                              \
    EXPECT_EQ(tellusTmpfsCode, 0) << "the test's run on the tmpfs failed (its output is above)";   \
  } while (false)
