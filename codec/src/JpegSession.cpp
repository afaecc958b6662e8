// libjpeg's error manager for every libjpeg use of tellus (see JpegSession.hpp).

#include "JpegSession.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <jerror.h> // after jpeglib.h: the message codes
#include <new>

namespace tellus::codec::detail {

namespace {

extern "C" void tellusJpegErrorExit(j_common_ptr c) {
  auto* s = reinterpret_cast<JpegErrorState*>(c->err);
  (*c->err->format_message)(c, s->message);
  std::longjmp(s->jump, 1);
}

extern "C" void tellusJpegMessage(j_common_ptr c, int level) {
  if (level >= 0) return; // trace messages
  auto* s = reinterpret_cast<JpegErrorState*>(c->err);
  if (!s->warned) (*c->err->format_message)(c, s->message);
  s->warned = true;
}

} // namespace

JpegErrors::JpegErrors() noexcept {
  std::memset(&state_, 0, sizeof state_);
  jpeg_std_error(&state_.mgr);
  state_.mgr.error_exit = tellusJpegErrorExit;
  state_.mgr.emit_message = tellusJpegMessage;
}

void JpegErrors::failOutOfMemory(j_common_ptr c) {
  c->err->msg_code = JERR_OUT_OF_MEMORY; // libjpeg's ERREXIT1, without its C casts
  c->err->msg_parm.i[0] = 10;
  (*c->err->error_exit)(c);
  std::abort(); // error_exit does not return
}

JpegDecompress::JpegDecompress(JpegErrors& errors) noexcept {
  // Zeroed: mem == nullptr until created, so that jpeg_destroy_decompress is a no-op then.
  std::memset(&info_, 0, sizeof info_);
  info_.err = errors.manager();
}

JpegDecompress::~JpegDecompress() {
  jpeg_destroy_decompress(&info_);
}

void JpegDecompress::create() {
  jpeg_create_decompress(&info_); // keeps `err`
}

void JpegDecompress::source(const void* bytes, std::size_t size) {
  jpeg_mem_src(&info_, static_cast<const unsigned char*>(bytes), static_cast<unsigned long>(size));
}

JpegCompress::JpegCompress(JpegErrors& errors) noexcept {
  std::memset(&info_, 0, sizeof info_);
  info_.err = errors.manager();
}

JpegCompress::~JpegCompress() {
  jpeg_destroy_compress(&info_);
}

void JpegCompress::create() {
  jpeg_create_compress(&info_);
}

struct JpegVectorDestinationAccess {
  static JpegVectorDestination* of(j_compress_ptr c) noexcept {
    return reinterpret_cast<JpegVectorDestination*>(c->dest);
  }
  static jpeg_destination_mgr& mgr(JpegVectorDestination* d) noexcept { return d->mgr_; }
  static std::vector<std::byte>& out(JpegVectorDestination* d) noexcept { return *d->out_; }
};

namespace {

using Access = JpegVectorDestinationAccess;

extern "C" void tellusJpegVectorInit(j_compress_ptr c) {
  auto* d = Access::of(c);
  auto& out = Access::out(d);
  Access::mgr(d).next_output_byte = reinterpret_cast<JOCTET*>(out.data());
  Access::mgr(d).free_in_buffer = out.size();
}

// Called when the buffer is full (all of it: libjpeg's contract), with libjpeg's frames below:
// the exception of a failed allocation is caught here and turned into libjpeg's error.
extern "C" boolean tellusJpegVectorEmpty(j_compress_ptr c) {
  auto* d = Access::of(c);
  auto& out = Access::out(d);
  const std::size_t used = out.size();
  bool grown = true;
  try {
    out.resize(std::max<std::size_t>(used * 2, 4096));
  } catch (const std::bad_alloc&) {
    grown = false;
  }
  if (!grown) JpegErrors::failOutOfMemory(reinterpret_cast<j_common_ptr>(c)); // outside the handler
  Access::mgr(d).next_output_byte = reinterpret_cast<JOCTET*>(out.data() + used);
  Access::mgr(d).free_in_buffer = out.size() - used;
  return TRUE;
}

extern "C" void tellusJpegVectorTerm(j_compress_ptr c) {
  auto* d = Access::of(c);
  auto& out = Access::out(d);
  out.resize(out.size() - Access::mgr(d).free_in_buffer);
}

} // namespace

JpegVectorDestination::JpegVectorDestination(std::vector<std::byte>& out) noexcept : out_(&out) {
  std::memset(&mgr_, 0, sizeof mgr_);
  mgr_.init_destination = tellusJpegVectorInit;
  mgr_.empty_output_buffer = tellusJpegVectorEmpty;
  mgr_.term_destination = tellusJpegVectorTerm;
}

void JpegVectorDestination::attach(jpeg_compress_struct* c) noexcept {
  c->dest = &mgr_;
}

} // namespace tellus::codec::detail
