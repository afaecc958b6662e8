#pragma once
// The one libjpeg error wrapper of tellus: every use of libjpeg(-turbo) in the project runs its
// library calls inside JpegErrors::run, on structures owned by JpegDecompress / JpegCompress.
//
// libjpeg reports a fatal error by calling error_exit, which must not return. Here it formats the
// message and longjmps back into run(), which returns false; the structures are then destroyed by
// their owners' destructors (in the caller's frame, which the longjmp does not leave). Warnings
// (corrupt data, a premature end of the stream that libjpeg pads with grey) do not stop a decode:
// the first one's message is kept and warned() says there was one; each caller decides (validation
// fails on them, composing ignores them). Trace messages are dropped; nothing goes to stderr.
//
// The rule that makes the longjmp well-defined C++: the body given to run() (and any callback
// libjpeg calls from it, such as a destination manager) keeps no object with a non-trivial
// destructor in its own frame (no std::string, no std::vector there: those belong to the caller,
// outside run(), where they are resized between runs). run() is never inlined (a function that
// calls setjmp cannot be), so the caller's locals are not clobbered by the jump. Allocating between
// two runs, in the caller, is the pattern: run() reads the header, the caller sizes its buffers,
// a second run() decodes into them.

#include <csetjmp>
#include <cstdio> // jpeglib.h needs FILE
#include <jpeglib.h>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace tellus::codec::detail {

/** libjpeg's error manager and what its callbacks keep (the manager first: libjpeg hands out a
 * pointer to it, which the callbacks cast back). */
struct JpegErrorState {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool warned;
};

class JpegErrors {
public:
  JpegErrors() noexcept;
  JpegErrors(const JpegErrors&) = delete; // libjpeg keeps a pointer to manager()
  JpegErrors& operator=(const JpegErrors&) = delete;

  /** What the structures' `err` must point to. */
  jpeg_error_mgr* manager() noexcept { return &state_.mgr; }

  /** Runs `body` (libjpeg calls only: see the rule above); false when libjpeg failed in it
   * (message() says why). May be called again after a failure: each run sets its own jump. */
  template <class Body> [[gnu::noinline]] bool run(Body&& body) {
    if (setjmp(state_.jump) != 0) return false;
    std::forward<Body>(body)();
    return true;
  }

  /** Whether libjpeg warned (corrupt data, a premature end) since construction. */
  bool warned() const noexcept { return state_.warned; }
  /** The failure's message, else the first warning's, else "". */
  std::string message() const { return state_.message; }
  /** For code that must fail from a callback (a destination out of memory): libjpeg's
   * JERR_OUT_OF_MEMORY through error_exit, so it longjmps like any libjpeg error. */
  [[noreturn]] static void failOutOfMemory(j_common_ptr c);

private:
  JpegErrorState state_;
};

/** A decompressor whose structure lives as long as this object (destroyed in the destructor,
 * also after a failed run). Call create() first, inside a run. */
class JpegDecompress {
public:
  explicit JpegDecompress(JpegErrors& errors) noexcept;
  ~JpegDecompress();
  JpegDecompress(const JpegDecompress&) = delete;
  JpegDecompress& operator=(const JpegDecompress&) = delete;

  /** jpeg_create_decompress (it may fail: inside a run). */
  void create();
  /** jpeg_mem_src over `size` bytes that outlive the decompressor's use of them. */
  void source(const void* bytes, std::size_t size);
  jpeg_decompress_struct* get() noexcept { return &info_; }
  jpeg_decompress_struct* operator->() noexcept { return &info_; }

private:
  jpeg_decompress_struct info_;
};

/** A compressor, as JpegDecompress. */
class JpegCompress {
public:
  explicit JpegCompress(JpegErrors& errors) noexcept;
  ~JpegCompress();
  JpegCompress(const JpegCompress&) = delete;
  JpegCompress& operator=(const JpegCompress&) = delete;

  void create();
  jpeg_compress_struct* get() noexcept { return &info_; }
  jpeg_compress_struct* operator->() noexcept { return &info_; }

private:
  jpeg_compress_struct info_;
};

/** A destination that writes into the caller's vector: its bytes from the start are the buffer
 * (size it to a first guess before the run), grown by doubling when full (out of memory: libjpeg's
 * error, through the error manager), cut to the stream's length when the compressor finishes.
 * Unlike jpeg_mem_dest, nothing is left to free and no pointer dangles after a failed run. */
class JpegVectorDestination {
public:
  explicit JpegVectorDestination(std::vector<std::byte>& out) noexcept;
  JpegVectorDestination(const JpegVectorDestination&) = delete;
  JpegVectorDestination& operator=(const JpegVectorDestination&) = delete;

  /** Makes this the compressor's destination (before jpeg_start_compress or
   * jpeg_write_coefficients). */
  void attach(jpeg_compress_struct* c) noexcept;

private:
  friend struct JpegVectorDestinationAccess;
  jpeg_destination_mgr mgr_; // first: libjpeg hands out a pointer to it
  std::vector<std::byte>* out_;
};
// It may live inside a run's body (one per tile of a split): nothing for a longjmp to skip.
static_assert(std::is_trivially_destructible_v<JpegVectorDestination>);

} // namespace tellus::codec::detail
