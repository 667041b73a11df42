// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The MuJoCo harness of the "true robot": loads an MJCF hopper, owns mjModel/mjData, keeps the
// VSA stiffness states beside the simulation, applies drag and pushes through xfrc_applied and
// detects touchdown/takeoff with the ContactPhaseDetector (the rule the controller plugin uses).
#ifndef DDOC_MUJOCO_HOPPER_SIM_H_
#define DDOC_MUJOCO_HOPPER_SIM_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <mujoco/mujoco.h>

#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/push.h"
#include "ddoc/hopper/vsa.h"
#include "ddoc/mujoco/contact_phase.h"
#include "ddoc/mujoco/hopper_mapping.h"

namespace ddoc {

/// Reads HopperParams from an MJCF hopper (throws HopperSimError naming file and element):
///   M      = mass of torso + leg + foot (the flight mass; the pinned foot is 0.02 % of it)
///   J_body = torso inertia about the y axis
///   J_leg  = inertia of leg + foot about the hip axis at r = r0 (leg I_yy + foot I_yy + m_f r0^2)
///   r0     = hip-to-foot distance at joint "leg" = 0;  c_d = <numeric drag_cd> (0 if absent);
///   beta   = <numeric vsa_beta> (20 if absent);  g = -opt.gravity[2];  impact = kMasslessLeg;
///   b_leg, b_hip = damping of joints "leg", "hip";  slope = the floor plane's tilt about y.
HopperParams LoadHopperParamsFromMjcf(const std::string& path);
/// The same from an already loaded model (source names it in errors).
HopperParams HopperParamsFromModel(const mjModel* m, const std::string& source);

/// Loads an MJCF file; errors (malformed XML, compiler errors such as non-positive mass) are
/// rethrown as HopperSimError "cannot load MJCF '<path>': <MuJoCo's message with element/line>".
struct MjModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MjDataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MjModelPtr = std::unique_ptr<mjModel, MjModelDeleter>;
using MjDataPtr = std::unique_ptr<mjData, MjDataDeleter>;
MjModelPtr LoadMjcf(const std::string& path);

/// A touchdown or takeoff measured on the MuJoCo robot by the ContactPhaseDetector.
struct ContactEvent {
  enum class Type { kTouchdown, kTakeoff };
  Type type = Type::kTouchdown;
  /// Time of the step at which the detector fired: touchdown, the last state before the impact;
  /// takeoff, the first state of the flight (ContactPhaseDetector).
  double time = 0.0;
  /// Touchdown: the flight state BEFORE the impact (at `time`). Takeoff: the flight state AFTER
  /// (the first flight state, at `time`).
  Eigen::Matrix<double, 14, 1> flight = Eigen::Matrix<double, 14, 1>::Zero();
  /// Touchdown: the stance state AFTER the impact (one step after `time`). Takeoff: the stance
  /// state BEFORE (the last stance state, one step before `time`).
  Eigen::Matrix<double, 10, 1> stance = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Vector2d foot = Eigen::Vector2d::Zero();  ///< foot centre at `time`, m
};

/// Settings of HopperSim.
struct HopperSimSettings {
  ContactPhaseSettings contact;  ///< the contact-phase detector; default ContactPhaseSettings{}
};

/// The MuJoCo hopper: mjModel/mjData (owned), VSA states (beside MuJoCo, advanced by the exact
/// ZOH step after every mj_step), drag, pushes and contact events.
class HopperSim {
 public:
  /// Loads `mjcf_path`; throws HopperSimError naming the file and element on any problem.
  explicit HopperSim(const std::string& mjcf_path,
                     const HopperSimSettings& settings = HopperSimSettings());

  /// Sets a flight state (14): qpos/qvel and the VSA states; time = t; mode = flight. The
  /// detector starts as after an event at t (no phase change within its min_phase_time).
  void SetFlightState(const Eigen::Matrix<double, 14, 1>& x, double t = 0.0);
  /// Sets a stance state (10) with the foot centre at (foot_x, 0); mode = stance (as above).
  void SetStanceState(const Eigen::Matrix<double, 10, 1>& x, double foot_x, double t = 0.0);

  /// One step: mj_step1 (the collision pass of the current state), contact detection, ctrl from
  /// u by WriteActuation, drag + active pushes into xfrc_applied, mj_step2, VSA advance with
  /// (u[2], u[3]) held. Returns true on an event (appended to events()).
  /// u = [tau0, F0, k0_hip, k0_leg]; bounds are NOT enforced here.
  bool Step(const Eigen::Vector4d& u);

  /// Current mode (hopper::kFlight or kStance) by the detector.
  int mode() const { return detector_.mode(); }
  /// Model-coordinate state of the current mode (14 or 10 entries).
  Eigen::VectorXd State() const;
  Eigen::Matrix<double, 14, 1> Flight() const { return FlightState(map_, data_.get(), vsa_.state()); }
  Eigen::Matrix<double, 10, 1> Stance() const { return StanceState(map_, data_.get(), vsa_.state()); }
  Eigen::Vector2d Foot() const { return FootPosition(map_, data_.get()); }
  double time() const { return data_->time; }
  double timestep() const { return model_->opt.timestep; }

  void AddPush(const Push& push) { pushes_.push_back(push); }
  void ClearPushes() { pushes_.clear(); }
  /// Sum of active push forces at time t, N (ddoc::PushForce).
  double PushForce(double t) const { return ddoc::PushForce(pushes_, t); }

  const std::vector<ContactEvent>& events() const { return events_; }
  void ClearEvents() { events_.clear(); }
  /// Sum of the foot-floor normal forces of the last step's constraint solve, N.
  double normal_force() const { return FootNormalForce(map_, model_.get(), data_.get()); }
  const HopperActuation& actuation() const { return actuation_; }

  const mjModel* model() const { return model_.get(); }
  mjData* data() { return data_.get(); }
  const mjData* data() const { return data_.get(); }
  const HopperMapping& mapping() const { return map_; }
  const Vsa& vsa() const { return vsa_; }
  Vsa& vsa() { return vsa_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  MjModelPtr model_;
  MjDataPtr data_;
  HopperMapping map_;
  Vsa vsa_;
  ContactPhaseDetector detector_;
  std::vector<Push> pushes_;
  std::vector<ContactEvent> events_;
  HopperActuation actuation_;
  // Stance coordinates of the current state and of the previous step's state.
  Eigen::Matrix<double, 10, 1> stance_now_ = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Matrix<double, 10, 1> stance_before_ = Eigen::Matrix<double, 10, 1>::Zero();
};

}  // namespace ddoc

#endif  // DDOC_MUJOCO_HOPPER_SIM_H_
