// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/render/png.h"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <lodepng.h>
#ifdef DDOC_RENDER_USE_ZLIB
#include <cstdlib>

#include <zlib.h>
#endif

namespace ddoc {
namespace {

#ifdef DDOC_RENDER_USE_ZLIB
// lodepng's custom_zlib hook: a complete zlib stream (header, deflate data, adler32) from
// zlib's compress2, at the level passed through custom_context. lodepng frees *out with
// free(), so allocate with malloc.
unsigned ZlibCompress(unsigned char** out, size_t* out_size, const unsigned char* in,
                      size_t in_size, const LodePNGCompressSettings* settings) {
  const int level = *static_cast<const int*>(settings->custom_context);
  uLongf size = compressBound(static_cast<uLong>(in_size));
  unsigned char* buffer = static_cast<unsigned char*>(std::malloc(size));
  if (!buffer) return 83;  // lodepng's "memory allocation failed"
  if (compress2(buffer, &size, in, static_cast<uLong>(in_size), level) != Z_OK) {
    std::free(buffer);
    return 111;  // lodepng's "custom zlib or inflate decompression failed"
  }
  *out = buffer;
  *out_size = size;
  return 0;
}
const int kFastLevel = 2;
const int kSmallLevel = 9;
#endif

}  // namespace

bool EncodePng(const std::vector<unsigned char>& rgb, int width, int height,
               std::vector<unsigned char>* png, std::string* error,
               PngCompression compression) {
  const size_t expected = 3 * static_cast<size_t>(width > 0 ? width : 0) *
                          static_cast<size_t>(height > 0 ? height : 0);
  if (width <= 0 || height <= 0 || rgb.size() != expected) {
    if (error) {
      *error = "EncodePng: rgb has " + std::to_string(rgb.size()) + " bytes, expected 3 * " +
               std::to_string(width) + " * " + std::to_string(height);
    }
    return false;
  }
  // 8-bit RGB in, 8-bit RGB out, no palette search. kFast uses row filter "none":
  // rendered frames are mostly flat colour, where deflate alone does well, and the
  // adaptive filter search would triple the encode time (see png.h).
  lodepng::State state;
  state.info_raw.colortype = LCT_RGB;
  state.info_raw.bitdepth = 8;
  state.info_png.color.colortype = LCT_RGB;
  state.info_png.color.bitdepth = 8;
  state.encoder.auto_convert = 0;
  const bool fast = compression == PngCompression::kFast;
  state.encoder.filter_strategy = fast ? LFS_ZERO : LFS_MINSUM;
#ifdef DDOC_RENDER_USE_ZLIB
  state.encoder.zlibsettings.custom_zlib = ZlibCompress;
  state.encoder.zlibsettings.custom_context = fast ? &kFastLevel : &kSmallLevel;
#else
  if (!fast) {
    state.encoder.zlibsettings.windowsize = 32768;
    state.encoder.zlibsettings.nicematch = 258;
  }
#endif
  png->clear();
  const unsigned code = lodepng::encode(*png, rgb, static_cast<unsigned>(width),
                                        static_cast<unsigned>(height), state);
  if (code != 0) {
    if (error) *error = std::string("EncodePng: lodepng error: ") + lodepng_error_text(code);
    return false;
  }
  return true;
}

bool WriteFileBytes(const std::string& path, const std::vector<unsigned char>& bytes,
                    std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    if (error) *error = "cannot write '" + path + "': " + std::strerror(errno);
    return false;
  }
  const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), f);
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (written != bytes.size() || !closed) {
    if (error) {
      *error = "cannot write '" + path + "': " +
               std::strerror(written != bytes.size() ? write_errno : errno);
    }
    return false;
  }
  return true;
}

bool WritePng(const std::string& path, const std::vector<unsigned char>& rgb, int width,
              int height, std::string* error, PngCompression compression) {
  std::vector<unsigned char> png;
  if (!EncodePng(rgb, width, height, &png, error, compression)) return false;
  return WriteFileBytes(path, png, error);
}

bool ReadPng(const std::string& path, std::vector<unsigned char>* rgb, int* width, int* height,
             std::string* error) {
  unsigned w = 0, h = 0;
  rgb->clear();
  const unsigned code = lodepng::decode(*rgb, w, h, path, LCT_RGB, 8);
  if (code != 0) {
    if (error) *error = "cannot read PNG '" + path + "': " + lodepng_error_text(code);
    return false;
  }
  *width = static_cast<int>(w);
  *height = static_cast<int>(h);
  return true;
}

}  // namespace ddoc
