#pragma once
// A JPEG with chosen sampling factors, written with libjpeg-turbo directly (the proxy's encoders
// write 4:2:0 only): tiles that the composer's YCbCr path must leave to the RGB path.

#include <cstddef>
#include <cstdint>
#include <cstdio> // jpeglib.h needs FILE
#include <cstdlib>
#include <cstring>
#include <jpeglib.h>
#include <vector>

namespace tellus::test {

/** Baseline JPEG (quality 75) of `rgb` (width * height * 3) with the luma sampled h x v (the
 * chroma 1 x 1): 1, 1 is 4:4:4, 2, 1 is 4:2:2, 2, 2 is 4:2:0. */
inline std::vector<std::byte>
jpegWithSampling(const std::vector<std::uint8_t>& rgb, int width, int height, int h, int v) {
  jpeg_compress_struct c;
  jpeg_error_mgr e;
  c.err = jpeg_std_error(&e);
  jpeg_create_compress(&c);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&c, &buffer, &size);
  c.image_width = static_cast<JDIMENSION>(width);
  c.image_height = static_cast<JDIMENSION>(height);
  c.input_components = 3;
  c.in_color_space = JCS_RGB;
  jpeg_set_defaults(&c);
  c.comp_info[0].h_samp_factor = h;
  c.comp_info[0].v_samp_factor = v;
  jpeg_start_compress(&c, TRUE);
  while (c.next_scanline < c.image_height) {
    auto* row = const_cast<JSAMPROW>(
        &rgb[static_cast<std::size_t>(c.next_scanline) * static_cast<std::size_t>(width) * 3]);
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  jpeg_destroy_compress(&c);
  std::vector<std::byte> out(size);
  std::memcpy(out.data(), buffer, size);
  std::free(buffer);
  return out;
}

} // namespace tellus::test
