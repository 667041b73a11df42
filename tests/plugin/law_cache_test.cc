// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The law cache (plugin/law_cache.h): a loaded u^0 steps the robot bitwise like a solved one;
// the key changes with every input of the model solve; a corrupt, truncated or foreign file and
// an unwritable directory make the controller solve (and say so), never fail or load bad data.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "law_cache.h"
#include "robot.h"

namespace ddoc::plugin {
namespace {

namespace fs = std::filesystem;

class LawCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ddoc_law_cache_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));  // two suites may run at once
    fs::remove_all(dir_);
    // Robot reads $DDOC_LAW_CACHE when config.law_cache is empty: this test chooses its own.
    const char* env = std::getenv("DDOC_LAW_CACHE");
    if (env != nullptr) saved_env_ = env;
    unsetenv("DDOC_LAW_CACHE");
  }
  void TearDown() override {
    fs::remove_all(dir_);
    if (!saved_env_.empty()) setenv("DDOC_LAW_CACHE", saved_env_.c_str(), 1);
  }

  ControllerConfig Config() const {
    ControllerConfig config;
    config.law_cache = dir_.string();
    return config;
  }

  fs::path dir_;
  std::string saved_env_;
};

bool StartsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

// The inputs written by the robot's controller over `hops` hops (its law, learning and all),
// with the controller's report of where u^0 came from.
struct Recorded {
  std::vector<double> ctrl;
  std::vector<double> costs;
  double model_cost = 0.0;
  int model_iterations = 0;
  std::string status;
  bool trouble = false;  // law_cache_trouble()
};

Recorded RunHops(const ControllerConfig& config, int hops) {
  Robot rig("hopper_m8.xml", config, false);
  Recorded run;
  if (!rig.ok()) return run;
  run.model_cost = rig.c().model_cost();
  run.model_iterations = rig.c().model_iterations();
  run.status = rig.c().law_cache_status();
  run.trouble = rig.c().law_cache_trouble();
  while (static_cast<int>(run.costs.size()) < hops && rig.d()->time < 10.0) {
    rig.Step();
    for (int i = 0; i < rig.m()->nu; ++i) run.ctrl.push_back(rig.d()->ctrl[i]);
    for (const HopReport& r : rig.c().TakeReports()) run.costs.push_back(r.cost);
  }
  return run;
}

TEST_F(LawCacheTest, ALoadedLawRunsBitwiseLikeTheSolvedOne) {
  // The first run solves (and stores), the second loads: the same inputs at every step.
  const Recorded solved = RunHops(Config(), 3);
  const std::string file = InitialLawPath(dir_.string(), InitialLawKey(Config()));
  EXPECT_EQ(solved.status, "stored " + file);
  ASSERT_TRUE(fs::exists(file));
  ASSERT_EQ(solved.costs.size(), 3u);
  const Recorded loaded = RunHops(Config(), 3);
  EXPECT_EQ(loaded.status, "loaded " + file);
  EXPECT_FALSE(solved.trouble);
  EXPECT_FALSE(loaded.trouble);
  EXPECT_EQ(loaded.model_cost, solved.model_cost);
  EXPECT_EQ(loaded.model_iterations, solved.model_iterations);
  EXPECT_EQ(loaded.costs, solved.costs);
  EXPECT_EQ(loaded.ctrl.size(), solved.ctrl.size());
  EXPECT_TRUE(loaded.ctrl == solved.ctrl) << "the inputs differ";
  // The file holds the model solve's cyclic value (n_0 = 14, the flight state), which the
  // robot learner's first pass starts from whether u^0 was solved or loaded.
  StoredInitialLaw stored;
  std::string why;
  ASSERT_TRUE(ReadInitialLaw(dir_.string(), InitialLawKey(Config()), &stored, &why)) << why;
  EXPECT_EQ(stored.cyclic_value.rows(), 14);
  EXPECT_EQ(stored.cyclic_value.cols(), 14);
  EXPECT_GT(stored.cyclic_value.norm(), 0.0);
}

// A loaded u^0 comes with the gait its solve started from, rebuilt from the search variables
// stored beside it (NominalGaitAt) instead of searching again: the file's variables are the
// loaded gait's.
TEST_F(LawCacheTest, TheGaitIsRebuiltFromTheStoredSearch) {
  Robot solved("hopper_m8.xml", Config(), false);
  ASSERT_TRUE(solved.ok());
  const NominalGait gait = solved.c().gait();
  StoredInitialLaw law;
  std::string why;
  ASSERT_TRUE(ReadInitialLaw(dir_.string(), InitialLawKey(Config()), &law, &why)) << why;
  EXPECT_TRUE(law.gait_search == gait.search);
  // A file whose search variables are another (valid) gait's: the loaded controller runs that
  // gait, so it did not search.
  law.gait_search(2) += 1e-3;
  ASSERT_TRUE(WriteInitialLaw(dir_.string(), InitialLawKey(Config()), law, &why)) << why;
  Robot loaded("hopper_m8.xml", Config(), false);
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(loaded.c().law_cache_status().rfind("loaded ", 0), 0u);
  EXPECT_TRUE(loaded.c().gait().search == law.gait_search);
  EXPECT_TRUE(loaded.c().gait().x0 ==
              NominalGaitAt(Config().model, Config().gait, law.gait_search).x0);
  EXPECT_FALSE(loaded.c().gait().x0 == gait.x0);
}

TEST_F(LawCacheTest, TheKeyHoldsEveryInputOfTheModelSolve) {
  const ControllerConfig base = Config();
  const std::string key = InitialLawKey(base);
  ASSERT_FALSE(key.empty()) << "no GNU build id found";
  EXPECT_NE(key.find("build_id.code="), std::string::npos) << key;
  std::vector<std::pair<const char*, void (*)(ControllerConfig*)>> changes = {
      {"model.M", [](ControllerConfig* c) { c->model.M = 10.0 + 1e-12; }},
      {"model.c_d", [](ControllerConfig* c) { c->model.c_d = 0.01; }},
      {"model.J_body", [](ControllerConfig* c) { c->model.J_body = 3.0; }},
      {"model.J_leg", [](ControllerConfig* c) { c->model.J_leg = 0.3; }},
      {"model.b_leg", [](ControllerConfig* c) { c->model.b_leg = 20.0; }},
      {"model.b_hip", [](ControllerConfig* c) { c->model.b_hip = 0.5; }},
      {"model.slope", [](ControllerConfig* c) { c->model.slope = -0.03; }},
      {"cost.q_diag", [](ControllerConfig* c) { c->cost_weights.q_diag(8) = 11.0; }},
      {"gait.forward_speed", [](ControllerConfig* c) { c->gait.forward_speed = 0.3; }},
      {"durations.stance_max", [](ControllerConfig* c) { c->durations.stance_max = 0.9; }},
      {"ocfb_alpha", [](ControllerConfig* c) { c->ocfb_alpha = 0.5; }},
      {"dt_model", [](ControllerConfig* c) { c->dt_model = 2e-3; }},
      {"learner.c", [](ControllerConfig* c) { c->model_learner.c = 1e-6; }},
      {"backward.cyclic_value",
       [](ControllerConfig* c) { c->model_learner.backward.cyclic_value = 0.9; }},
      {"qp.tolerance",
       [](ControllerConfig* c) { c->model_learner.controller.qp.tolerance = 1e-10; }},
      {"state_feedback_scale",
       [](ControllerConfig* c) {
         c->model_learner.controller.state_feedback_scale = {Vector::Ones(14), Vector::Ones(10)};
       }},
  };
  for (const auto& [name, change] : changes) {
    ControllerConfig changed = base;
    change(&changed);
    EXPECT_NE(InitialLawKey(changed), key) << name;
    EXPECT_NE(InitialLawPath("d", InitialLawKey(changed)), InitialLawPath("d", key)) << name;
  }
  // What the model solve does not read leaves the key as it is.
  ControllerConfig other = base;
  other.driver.method = Method::kOcfb;
  other.offline_latency = 0.0;
  other.anchor_reference = false;
  other.law_cache = "elsewhere";
  EXPECT_EQ(InitialLawKey(other), key);
}

TEST_F(LawCacheTest, AnUnusableFileIsSolvedAgainAndReplaced) {
  const Recorded reference = RunHops(Config(), 2);
  const std::string file = InitialLawPath(dir_.string(), InitialLawKey(Config()));
  ASSERT_EQ(reference.status, "stored " + file);
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 1000u);
  auto write = [&file](const std::string& data) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << data;
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  std::string other_key = InitialLawKey(Config());
  other_key[other_key.size() - 2] ^= 1;  // a law stored for another key, under this file name
  StoredInitialLaw law;
  std::string why;
  ASSERT_TRUE(ReadInitialLaw(dir_.string(), InitialLawKey(Config()), &law, &why)) << why;
  ASSERT_TRUE(WriteInitialLaw((dir_ / "other").string(), other_key, law, &why)) << why;
  std::string foreign;
  {
    std::ifstream in(InitialLawPath((dir_ / "other").string(), other_key), std::ios::binary);
    foreign.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // Each way a file can be unusable is read as no law, with the reason.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {flipped, "checksum mismatch (truncated or corrupt)"},
      {bytes.substr(0, bytes.size() / 3), "checksum mismatch (truncated or corrupt)"},
      {std::string("DDOC"), "truncated file"},
      {std::string(bytes.size(), 'x'), "not a ddoc law file"},
      {foreign, "stored for another key"},
  };
  for (const auto& [data, reason] : cases) {
    write(data);
    EXPECT_FALSE(ReadInitialLaw(dir_.string(), InitialLawKey(Config()), &law, &why)) << reason;
    EXPECT_EQ(why, reason);
  }
  // A well-formed file whose law the controller rejects (a NaN gain): the controller solves,
  // runs as before and replaces the file. One case only: each solve takes seconds, more under
  // the sanitizers.
  write(bytes);
  ASSERT_TRUE(ReadInitialLaw(dir_.string(), InitialLawKey(Config()), &law, &why)) << why;
  law.law.Kx(5, 7) = std::numeric_limits<double>::quiet_NaN();
  ASSERT_TRUE(WriteInitialLaw(dir_.string(), InitialLawKey(Config()), law, &why)) << why;
  const Recorded run = RunHops(Config(), 2);
  EXPECT_EQ(run.status, "stored " + file + " (" + file +
                            ": OnlineController::ImportLaw: Kx has a non-finite entry)");
  EXPECT_TRUE(run.trouble);
  EXPECT_EQ(run.costs, reference.costs);
  EXPECT_TRUE(run.ctrl == reference.ctrl);
  EXPECT_EQ(RunHops(Config(), 0).status, "loaded " + file);
}

// A small well-formed law (two modes, two samples each, one state, one input).
StoredInitialLaw TinyLaw() {
  StoredInitialLaw s;
  s.law.samples = {2, 2};
  s.law.dT = Vector::Zero(2);
  s.law.nominal_T = Vector::LinSpaced(2, 0.1, 0.2);
  s.law.tau = Vector::LinSpaced(4, 0.0, 2.0);
  for (Matrix* a : {&s.law.x, &s.law.u, &s.law.Kx, &s.law.c, &s.law.huu}) *a = Matrix::Ones(1, 4);
  s.model_cost = 1.5;
  s.model_iterations = 3;
  s.cyclic_value = Matrix::Constant(1, 1, 2.5);
  return s;
}

TEST_F(LawCacheTest, TheModelSolvesCyclicValueIsStoredWithTheLaw) {
  // Since format 2: the cyclic value after the law, which the robot learner's first pass starts from;
  // a law without one (n_0 = 0) reads back as an empty matrix, a wrong size is named.
  StoredInitialLaw tiny = TinyLaw();
  for (const Matrix& P0 : {Matrix(Matrix::Constant(1, 1, 2.5)), Matrix()}) {
    tiny.cyclic_value = P0;
    const std::string file = SerializeInitialLaw("key", tiny);
    StoredInitialLaw back;
    std::string why;
    ASSERT_TRUE(ParseInitialLaw(file, "key", &back, &why)) << why;
    EXPECT_EQ(back.cyclic_value.rows(), P0.rows());
    EXPECT_TRUE(back.cyclic_value == P0);
  }
  tiny.cyclic_value = Matrix::Constant(2, 2, 1.0);  // more than n_max = 1 allows
  StoredInitialLaw back;
  std::string why;
  EXPECT_FALSE(ParseInitialLaw(SerializeInitialLaw("key", tiny), "key", &back, &why));
  EXPECT_EQ(why, "array sizes do not match the file length");
  tiny.cyclic_value = Matrix::Constant(1, 1, std::numeric_limits<double>::infinity());
  EXPECT_FALSE(ParseInitialLaw(SerializeInitialLaw("key", tiny), "key", &back, &why));
  EXPECT_EQ(why, "non-finite cyclic value");
}

TEST_F(LawCacheTest, ADirectoryKeepsTheMostRecentlyUsedLaws) {
  const StoredInitialLaw tiny = TinyLaw();
  std::string why;
  const auto now = fs::file_time_type::clock::now();
  // 70 old law files, the oldest first (key 0 a real law, the others only named like one); then
  // key 0 is read, which makes it the most recently used.
  ASSERT_TRUE(WriteInitialLaw(dir_.string(), "key 0", tiny, &why)) << why;
  for (int i = 0; i < 70; ++i) {
    const std::string file = InitialLawPath(dir_.string(), "key " + std::to_string(i));
    if (i > 0) std::ofstream(file) << "old";
    fs::last_write_time(file, now - std::chrono::hours(100 - i));
  }
  std::ofstream(dir_ / "notes.txt") << "not a law";
  fs::last_write_time(dir_ / "notes.txt", now - std::chrono::hours(1000));
  StoredInitialLaw read;
  ASSERT_TRUE(ReadInitialLaw(dir_.string(), "key 0", &read, &why)) << why;
  EXPECT_EQ(read.model_cost, 1.5);
  EXPECT_EQ(read.law.Kx, tiny.law.Kx);
  ASSERT_TRUE(WriteInitialLaw(dir_.string(), "new key", tiny, &why)) << why;
  int laws = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    laws += entry.path().extension() == ".law" ? 1 : 0;
  }
  EXPECT_EQ(laws, kLawCacheCapacity);
  EXPECT_TRUE(fs::exists(InitialLawPath(dir_.string(), "new key")));
  EXPECT_TRUE(fs::exists(InitialLawPath(dir_.string(), "key 0")));  // read: recently used
  for (int i = 1; i <= 7; ++i) {  // 71 laws: the 7 least recently used went
    EXPECT_FALSE(fs::exists(InitialLawPath(dir_.string(), "key " + std::to_string(i)))) << i;
  }
  EXPECT_TRUE(fs::exists(InitialLawPath(dir_.string(), "key 8")));
  EXPECT_TRUE(fs::exists(dir_ / "notes.txt"));  // not a law: never removed
}

TEST_F(LawCacheTest, AnUnwritableDirectoryOnlyMeansSolving) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "a_file") << "not a directory";
  ControllerConfig config = Config();
  config.law_cache = (dir_ / "a_file").string();
  const Recorded run = RunHops(config, 1);
  EXPECT_TRUE(StartsWith(run.status, "solved; not stored: cannot create ")) << run.status;
  EXPECT_TRUE(run.trouble);
  EXPECT_EQ(run.costs.size(), 1u);
}

}  // namespace
}  // namespace ddoc::plugin
