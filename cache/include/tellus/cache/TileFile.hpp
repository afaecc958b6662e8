#pragma once
/**
 * @file TileFile.hpp
 * @brief A cached tile held open: its descriptor and size, shared between the cache's descriptor
 * cache and whoever is sending it (the HTTP server hands it to sendfile(2)).
 *
 * The descriptor is read-only and closed when the last owner lets go. A tile replaced or removed
 * while a TileFile is held keeps its old bytes for that holder (POSIX unlink/rename semantics), so
 * a response being sent is never torn.
 */

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace tellus {

class TileFile {
public:
  /** Takes ownership of `fd` (opened O_RDONLY), whose file is `size` bytes long. */
  TileFile(int fd, std::int64_t size) noexcept : fd_(fd), size_(size) {}
  ~TileFile();
  TileFile(const TileFile&) = delete;
  TileFile& operator=(const TileFile&) = delete;

  int fd() const noexcept { return fd_; }
  std::int64_t size() const noexcept { return size_; }

  /** All of the file's bytes (pread from offset 0); nullopt when it reads short or fails. */
  std::optional<std::vector<std::byte>> readAll() const;

private:
  int fd_;
  std::int64_t size_;
};

} // namespace tellus
