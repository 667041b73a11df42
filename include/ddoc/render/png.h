// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// PNG encoding of rendered frames with lodepng (and zlib's deflate when available).
#ifndef DDOC_RENDER_PNG_H_
#define DDOC_RENDER_PNG_H_

#include <string>
#include <vector>

namespace ddoc {

/// Speed/size trade-off of EncodePng.
enum class PngCompression {
  /// For video frames: row filter "none" + zlib level 2 (lodepng's own deflate without zlib).
  kFast,
  /// For images kept in the repository: adaptive row filter + zlib level 9.
  kSmall,
};

/// Encodes an 8-bit RGB image (rgb: 3 * width * height bytes, top row first) as a PNG
/// into *png. Returns false and sets *error (if non-null) on failure (e.g. a size
/// mismatch: "EncodePng: rgb has N bytes, expected 3 * W * H").
bool EncodePng(const std::vector<unsigned char>& rgb, int width, int height,
               std::vector<unsigned char>* png, std::string* error,
               PngCompression compression = PngCompression::kFast);

/// EncodePng, then writes the bytes to path (replacing it). The message of a failure names
/// the path and the reason (e.g. "cannot write 'x/frame_000001.png': No such file or
/// directory").
bool WritePng(const std::string& path, const std::vector<unsigned char>& rgb, int width,
              int height, std::string* error,
              PngCompression compression = PngCompression::kFast);

/// Writes already encoded bytes to path (replacing it); error message as in WritePng.
bool WriteFileBytes(const std::string& path, const std::vector<unsigned char>& bytes,
                    std::string* error);

/// Reads a PNG file as 8-bit RGB (top row first). For tests and tools.
bool ReadPng(const std::string& path, std::vector<unsigned char>* rgb, int* width, int* height,
             std::string* error);

}  // namespace ddoc

#endif  // DDOC_RENDER_PNG_H_
