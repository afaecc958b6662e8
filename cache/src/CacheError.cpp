#include <tellus/cache/CacheError.hpp>

namespace tellus {

const char* toString(CacheErrc code) noexcept {
  switch (code) {
  case CacheErrc::InvalidArgument:
    return "invalid argument";
  case CacheErrc::Io:
    return "i/o error";
  case CacheErrc::DiskFull:
    return "disk full";
  case CacheErrc::Corrupt:
    return "corrupt index";
  case CacheErrc::Schema:
    return "unsupported index schema";
  case CacheErrc::ReadOnly:
    return "read-only cache";
  }
  return "unknown error";
}

} // namespace tellus
