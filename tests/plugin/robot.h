// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The plugin tests' robot: an MJCF hopper (mjModel/mjData) with a HopperController, stepped as a
// host loop steps it.
#ifndef DDOC_TESTS_PLUGIN_ROBOT_H_
#define DDOC_TESTS_PLUGIN_ROBOT_H_

#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"

namespace ddoc::plugin {

/// What the host does after each physics step.
enum class Host {
  kRunsOffline,     ///< RunOffline() when a hop waits for it (what ddoc-hopper does)
  kWaitsForWorker,  ///< FinishOffline(): waits for the worker thread, takes its result
  kNothing,         ///< nothing: the offline part stays pending
};

/// `config` with law_cache = $DDOC_LAW_CACHE when it is unset (ctest sets the variable to the
/// build tree's shared directory of stored u^0 laws; tests/CMakeLists.txt).
inline ControllerConfig WithTestLawCache(ControllerConfig config) {
  const char* dir = std::getenv("DDOC_LAW_CACHE");
  if (config.law_cache.empty() && dir != nullptr) config.law_cache = dir;
  return config;
}

class Robot {
 public:
  /// The robot models/<mjcf> with a controller of `config` at 0.5 m/s, Reset. With exact_model
  /// the controller's model is read from the same MJCF. A failed Create fails the test.
  /// `edit`, when given, changes the compiled mjModel before the controller is created (a
  /// variant without a file, e.g. a weaker motor's gainprm).
  Robot(const std::string& mjcf, ControllerConfig config, bool exact_model,
        void (*edit)(mjModel*) = nullptr) {
    const std::string path = std::string(DDOC_MODELS_DIR) + "/" + mjcf;
    model_ = LoadMjcf(path);
    if (edit != nullptr) edit(model_.get());
    data_.reset(mj_makeData(model_.get()));
    config.gait.forward_speed = 0.5;
    if (exact_model) config.model = LoadHopperParamsFromMjcf(path);
    std::string error;
    controller_ = HopperController::Create(model_.get(), WithTestLawCache(config), &error);
    EXPECT_TRUE(controller_) << error;
    if (controller_) Restart();
  }
  ~Robot() { Detach(); }
  Robot(const Robot&) = delete;
  Robot& operator=(const Robot&) = delete;

  void Restart() { controller_->Reset(model_.get(), data_.get()); }
  /// One physics step with the robot's drag, then the host's part; returns the foot-floor normal
  /// force after the step. Attaches this robot's controller first (mjcb_control is global).
  double Step(Host host = Host::kRunsOffline) {
    Attach(controller_.get());
    ApplyDragAndPush(controller_->mapping(), model_.get(), data_.get(), 0.0);
    mj_step(model_.get(), data_.get());
    if (host == Host::kRunsOffline && controller_->offline_pending()) controller_->RunOffline();
    if (host == Host::kWaitsForWorker) controller_->FinishOffline();
    return FootNormalForce(controller_->mapping(), model_.get(), data_.get());
  }
  /// Steps until `hops` hops have reports (or 20 s); returns them.
  std::vector<HopReport> Run(int hops, Host host) {
    std::vector<HopReport> reports;
    while (static_cast<int>(reports.size()) < hops && data_->time < 20.0) {
      Step(host);
      for (const HopReport& r : controller_->TakeReports()) reports.push_back(r);
      EXPECT_FALSE(controller_->failed()) << controller_->error();
    }
    return reports;
  }

  const mjModel* m() const { return model_.get(); }
  mjData* d() { return data_.get(); }
  HopperController& c() { return *controller_; }
  bool ok() const { return controller_ != nullptr; }

 private:
  MjModelPtr model_;
  MjDataPtr data_;
  std::unique_ptr<HopperController> controller_;
};

}  // namespace ddoc::plugin

#endif  // DDOC_TESTS_PLUGIN_ROBOT_H_
