// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// Test helper: copies of the shipped MJCF files in a temporary directory, to break on purpose.
#ifndef DDOC_TESTS_MUJOCO_MODEL_FILES_H_
#define DDOC_TESTS_MUJOCO_MODEL_FILES_H_

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace ddoc {
namespace testing {

inline std::string ModelPath(const std::string& name) {
  return std::string(DDOC_MODELS_DIR) + "/" + name;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// A temporary copy of models/hopper*.xml; Edit() replaces text in one file.
class ModelCopy {
 public:
  ModelCopy() {
    char tmpl[] = "/tmp/ddoc_hopper_mjcf_XXXXXX";
    dir_ = mkdtemp(tmpl);
    for (const char* f : {"hopper.xml", "hopper_m8.xml", "hopper_m12.xml", "hopper_common.xml",
                          "hopper_limbs.xml"}) {
      Write(f, ReadText(ModelPath(f)));
    }
  }
  ~ModelCopy() { std::system(("rm -rf '" + dir_ + "'").c_str()); }
  std::string Path(const std::string& f) const { return dir_ + "/" + f; }
  void Write(const std::string& f, const std::string& text) const {
    std::ofstream(Path(f)) << text;
  }
  /// Replaces the first occurrence of `from` by `to` in file f; fails the test if absent.
  void Edit(const std::string& f, const std::string& from, const std::string& to) const {
    std::string text = ReadText(Path(f));
    const size_t pos = text.find(from);
    ASSERT_NE(pos, std::string::npos) << "'" << from << "' not in " << f;
    text.replace(pos, from.size(), to);
    Write(f, text);
  }

 private:
  std::string dir_;
};

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_MUJOCO_MODEL_FILES_H_
