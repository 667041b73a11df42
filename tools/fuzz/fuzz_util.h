// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// What the file-based fuzz targets share: a private copy of models/ in a temporary directory
// (so that relative paths and <include>s of the inputs resolve as in the real tree) and
// writing one input to a file in it.
#ifndef DDOC_TOOLS_FUZZ_FUZZ_UTIL_H_
#define DDOC_TOOLS_FUZZ_FUZZ_UTIL_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace ddoc::fuzz {

/// A copy of DDOC_MODELS_DIR (MJCFs and scenarios/) in $TMPDIR/ddoc_fuzz_<tag>_<pid>, made once
/// per process and removed when the process exits through exit() (static destruction).
/// tools/fuzz/run_all.sh also points TMPDIR at a directory it removes itself.
inline const std::filesystem::path& ModelsCopy(const char* tag) {
  namespace fs = std::filesystem;
  struct Copy {
    fs::path dir;
    explicit Copy(const char* t)
        : dir(fs::temp_directory_path() /
              ("ddoc_fuzz_" + std::string(t) + "_" + std::to_string(getpid()))) {
      fs::remove_all(dir);
      fs::create_directories(dir);
      fs::copy(DDOC_MODELS_DIR, dir, fs::copy_options::recursive);
    }
    ~Copy() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  };
  static const Copy copy(tag);
  return copy.dir;
}

/// Writes the input to `path` (truncating) and returns it.
inline std::string WriteInput(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path.string();
}

}  // namespace ddoc::fuzz

#endif  // DDOC_TOOLS_FUZZ_FUZZ_UTIL_H_
