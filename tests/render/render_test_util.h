// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Shared helpers of the render tests: small embedded MJCF models, model loading through
// MuJoCo's VFS, a warning trap, temporary directories and image statistics.
#ifndef DDOC_TESTS_RENDER_RENDER_TEST_UTIL_H_
#define DDOC_TESTS_RENDER_RENDER_TEST_UTIL_H_

#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

namespace ddoc {
namespace testing {

/// A capsule "torso" on slide-x / slide-z / hinge-y joints (planar, like the hopper) over a
/// floor. floor_material: "" for an untextured floor, else the attributes of a checker
/// texture floor. A motor on the x slide lets tests push the body sideways.
inline std::string TestModelXml(bool textured_floor) {
  const std::string asset =
      textured_floor ? R"(
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1=".25 .3 .35" rgb2=".4 .45 .5"
             width="256" height="256" mark="edge" markrgb=".9 .9 .9"/>
    <material name="grid" texture="grid" texrepeat="2 2" texuniform="true"/>
  </asset>)"
                     : "";
  const std::string floor = textured_floor
                                ? R"(<geom name="floor" type="plane" size="0 0 1" material="grid"/>)"
                                : R"(<geom name="floor" type="plane" size="0 0 1" rgba=".8 .85 .9 1"/>)";
  return R"(<mujoco model="render_test">
  <option timestep="0.002"/>)" +
         asset + R"(
  <worldbody>
    <light pos="0 -1 4" dir="0 .25 -1"/>
    )" + floor + R"(
    <body name="torso" pos="0 0 0.5">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="pitch" type="hinge" axis="0 1 0"/>
      <geom name="capsule" type="capsule" size=".08 .2" rgba="1 0 0 1" friction="1"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="push" joint="x" gear="20" ctrllimited="true" ctrlrange="-1 1"/>
  </actuator>
</mujoco>)";
}

/// Loads MJCF text through MuJoCo's virtual file system; fails the test on error.
inline std::unique_ptr<mjModel, void (*)(mjModel*)> LoadModel(const std::string& xml) {
  auto vfs = std::make_unique<mjVFS>();  // ~2 MB: keep it off the stack
  mj_defaultVFS(vfs.get());
  mj_makeEmptyFileVFS(vfs.get(), "model.xml", static_cast<int>(xml.size()));
  const int index = mj_findFileVFS(vfs.get(), "model.xml");
  std::memcpy(vfs->filedata[index], xml.data(), xml.size());
  char error[1000] = "";
  mjModel* m = mj_loadXML("model.xml", vfs.get(), error, sizeof(error));
  mj_deleteVFS(vfs.get());
  // Throwing fails the calling test (gtest catches it) instead of crashing on a null model.
  if (!m) throw std::runtime_error(std::string("cannot load the test MJCF: ") + error);
  return {m, mj_deleteModel};
}

inline std::unique_ptr<mjData, void (*)(mjData*)> MakeData(const mjModel* m) {
  return {mj_makeData(m), mj_deleteData};
}

/// Fixture that fails on any MuJoCo warning and gives each test a fresh temporary directory.
class RenderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    warnings().clear();
    previous_warning_ = mju_user_warning;
    mju_user_warning = [](const char* msg) { warnings().push_back(msg); };
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("ddoc_render_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
            std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
  }
  void TearDown() override {
    mju_user_warning = previous_warning_;
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
    for (const std::string& w : warnings()) ADD_FAILURE() << "MuJoCo warning: " << w;
  }
  static std::vector<std::string>& warnings() {
    static std::vector<std::string> list;
    return list;
  }
  std::filesystem::path dir_;

 private:
  void (*previous_warning_)(const char*) = nullptr;
};

/// Number of *.png files named frame_NNNNNN.png in dir.
inline int CountFrames(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() == 16 && name.rfind("frame_", 0) == 0 &&
        name.compare(12, 4, ".png") == 0) {
      ++n;
    }
  }
  return n;
}

/// Pixel (col, row) of an RGB image stored top row first.
inline const unsigned char* Pixel(const std::vector<unsigned char>& rgb, int width, int col,
                                  int row) {
  return rgb.data() + 3 * (static_cast<size_t>(row) * width + col);
}

inline bool IsRed(const unsigned char* p) { return p[0] > 120 && p[1] < 80 && p[2] < 80; }

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_RENDER_RENDER_TEST_UTIL_H_
