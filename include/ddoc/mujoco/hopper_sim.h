// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The MuJoCo harness of the "true robot": loads an MJCF hopper, owns mjModel/mjData, keeps the
// VSA stiffness states beside the simulation, applies drag and pushes through xfrc_applied and
// detects touchdown/takeoff from the foot-floor normal force with hysteresis.
#ifndef DDOC_MUJOCO_HOPPER_SIM_H_
#define DDOC_MUJOCO_HOPPER_SIM_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <mujoco/mujoco.h>

#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/vsa.h"
#include "ddoc/mujoco/hopper_mapping.h"

namespace ddoc {

/// Reads HopperParams from an MJCF hopper (throws HopperSimError naming file and element):
///   M      = mass of torso + leg + foot (the flight mass; the pinned foot is 0.02 % of it)
///   J_body = torso inertia about the y axis
///   J_leg  = inertia of leg + foot about the hip axis at r = r0 (leg I_yy + foot I_yy + m_f r0^2)
///   r0     = hip-to-foot distance at joint "leg" = 0;  c_d = <numeric drag_cd> (0 if absent);
///   beta   = <numeric vsa_beta> (20 if absent);  g = -opt.gravity[2];  impact = kMasslessLeg.
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

/// Settings of the contact-phase detector (hysteresis on the foot-floor normal force).
struct ContactDetectorSettings {
  double touchdown_force = 1.0;  ///< flight -> stance when the normal force exceeds this, N
  double takeoff_force = 0.1;    ///< stance -> flight when it drops below this, N
  double min_phase_time = 0.02;  ///< no switch back within this time after an event, s
};

/// A touchdown or takeoff measured on the MuJoCo robot.
struct ContactEvent {
  enum class Type { kTouchdown, kTakeoff };
  Type type = Type::kTouchdown;
  /// Time of the forward pass in which the normal force crossed the threshold, i.e. the start of
  /// the step during which the contact impulse (touchdown) acted / the last contact step ended.
  double time = 0.0;
  /// Touchdown: the flight state BEFORE (at `time`, before the impulse). Takeoff: the flight state
  /// AFTER (one step later, at time + dt).
  Eigen::Matrix<double, 14, 1> flight = Eigen::Matrix<double, 14, 1>::Zero();
  /// Touchdown: the stance state AFTER (at time + dt). Takeoff: the stance state BEFORE (at time).
  Eigen::Matrix<double, 10, 1> stance = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Vector2d foot = Eigen::Vector2d::Zero();  ///< foot centre at the event
  double normal_force = 0.0;  ///< the force that triggered the event, N
};

/// Contact-phase detector. Call Update() after every mj_step (it needs d->efc_force of the
/// step's forward pass). Allocation-free.
class ContactPhaseDetector {
 public:
  explicit ContactPhaseDetector(const ContactDetectorSettings& s = ContactDetectorSettings());

  /// Starts in `mode` (hopper::kFlight or kStance) at the current state of d.
  void Reset(int mode, const HopperMapping& map, const mjData* d, const VsaState& vsa);
  /// Returns true when an event happened in the last step; event() then holds it.
  bool Update(const HopperMapping& map, const mjModel* m, const mjData* d, const VsaState& vsa);

  int mode() const { return mode_; }
  const ContactEvent& event() const { return event_; }
  double normal_force() const { return normal_force_; }

 private:
  ContactDetectorSettings s_;
  int mode_ = 0;                         // hopper::kFlight / kStance
  double last_event_time_ = -1e300;      // s
  double prev_time_ = 0.0;               // time of the previous Update, s
  Eigen::Matrix<double, 14, 1> prev_flight_ = Eigen::Matrix<double, 14, 1>::Zero();
  Eigen::Matrix<double, 10, 1> prev_stance_ = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Vector2d prev_foot_ = Eigen::Vector2d::Zero();
  double normal_force_ = 0.0;            // N, of the last step
  ContactEvent event_;
};

/// A horizontal push on the COM (Section V-D disturbance rejection).
struct Push {
  double force_x = 0.0;   ///< N (F_b = -20, F_f = 25 in the paper)
  double start = 0.0;     ///< s, simulation time
  double duration = 0.0;  ///< s
};

/// Settings of HopperSim.
struct HopperSimSettings {
  ContactDetectorSettings detector;  ///< contact hysteresis
};

/// The MuJoCo hopper: mjModel/mjData (owned), VSA states (beside MuJoCo, advanced by the exact
/// ZOH step after every mj_step), drag, pushes and contact events.
class HopperSim {
 public:
  /// Loads `mjcf_path`; throws HopperSimError naming the file and element on any problem.
  explicit HopperSim(const std::string& mjcf_path,
                     const HopperSimSettings& settings = HopperSimSettings());

  /// Sets a flight state (14): qpos/qvel and the VSA states; time = t; mode = flight.
  void SetFlightState(const Eigen::Matrix<double, 14, 1>& x, double t = 0.0);
  /// Sets a stance state (10) with the foot centre at (foot_x, 0); mode = stance.
  void SetStanceState(const Eigen::Matrix<double, 10, 1>& x, double foot_x, double t = 0.0);

  /// One step: ctrl from u by WriteActuation, drag + active pushes into xfrc_applied, mj_step,
  /// VSA advance with (u[2], u[3]) held, contact detection. Returns true on an event (appended to
  /// events()). u = [tau0, F0, k0_hip, k0_leg]; bounds are NOT enforced here.
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
  /// Sum of active push forces at time t.
  double PushForce(double t) const;

  const std::vector<ContactEvent>& events() const { return events_; }
  void ClearEvents() { events_.clear(); }
  double normal_force() const { return detector_.normal_force(); }
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
};

}  // namespace ddoc

#endif  // DDOC_MUJOCO_HOPPER_SIM_H_
