#pragma once
// The proxy's side of the imaging module (tellus/imaging/ImagingApi.hpp): the function table,
// loaded with dlopen() on first use, and sinks that collect what the module hands back.

#include <tellus/imaging/ImagingApi.hpp>

#include <cstddef>
#include <expected>
#include <string>
#include <vector>

namespace tellus::imaging {

/** The module's function table, loading the module on first use (thread-safe, tried once per
 * process); else "cannot load the imaging module <path>: <why>". */
std::expected<const TellusImagingTable*, std::string> table();

/** Receives a module call's output and error text; one per call, on the caller's stack. */
class Sink {
public:
  Sink(const Sink&) = delete;
  Sink& operator=(const Sink&) = delete;
  virtual ~Sink() = default;

  const TellusImagingSink* get() const noexcept { return &sink_; }
  /** The module's error text ("" when it gave none). */
  const std::string& error() const noexcept { return error_; }

protected:
  Sink() noexcept : sink_{this, &Sink::allocateThunk, &Sink::failThunk} {}
  /** Storage for `size` bytes (may throw: the thunk turns that into nullptr). */
  virtual void* allocate(std::size_t size) = 0;

private:
  static void* allocateThunk(void* context, std::size_t size) noexcept;
  static void failThunk(void* context, const char* message, std::size_t length) noexcept;

  TellusImagingSink sink_;
  std::string error_;
};

/** Collects encoded bytes. */
class BytesSink final : public Sink {
public:
  std::vector<std::byte> bytes;

private:
  void* allocate(std::size_t size) override;
};

/** For calls that only report errors. */
class ErrorSink final : public Sink {
private:
  void* allocate(std::size_t) override { return nullptr; }
};

} // namespace tellus::imaging
