// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/mujoco/hopper_sim.h"

#include <cmath>
#include <sstream>

#include "mjcf_precheck.h"

namespace ddoc {

MjModelPtr LoadMjcf(const std::string& path) {
  PrecheckMjcf(path);  // file, XML syntax, masses/inertias: errors name file, line, element
  char err[1024] = {0};
  mjModel* m = mj_loadXML(path.c_str(), nullptr, err, sizeof(err));
  if (!m) throw HopperSimError("cannot load MJCF '" + path + "': " + err);
  return MjModelPtr(m);
}

HopperParams HopperParamsFromModel(const mjModel* m, const std::string& source) {
  const HopperMapping map = HopperMapping::Build(m, source);
  // Inertias about the world y axis at qpos0 (robust to rotated inertial frames).
  MjDataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  auto inertia_y = [&](int b) {
    double s = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double a = d->ximat[9 * b + 3 + i];  // y component of principal axis i
      s += m->body_inertia[3 * b + i] * a * a;
    }
    return s;
  };
  HopperParams p;
  const double m_foot = m->body_mass[map.body_foot];
  p.M = m->body_mass[map.body_torso] + m->body_mass[map.body_leg] + m_foot;
  p.J_body = inertia_y(map.body_torso);
  p.J_leg = inertia_y(map.body_leg) + inertia_y(map.body_foot) + m_foot * map.r0 * map.r0;
  p.r0 = map.r0;
  p.c_d = map.drag_cd;
  p.beta = map.beta;
  p.g = -m->opt.gravity[2];
  p.impact = ImpactModel::kMasslessLeg;
  try {
    p.Validate();
  } catch (const InvalidArgument& e) {
    throw HopperSimError("hopper MJCF '" + source + "': " + e.what());
  }
  return p;
}

HopperParams LoadHopperParamsFromMjcf(const std::string& path) {
  MjModelPtr m = LoadMjcf(path);
  return HopperParamsFromModel(m.get(), path);
}

ContactPhaseDetector::ContactPhaseDetector(const ContactDetectorSettings& s) : s_(s) {
  if (!(s.touchdown_force > s.takeoff_force) || !(s.takeoff_force >= 0.0) ||
      !(s.min_phase_time >= 0.0)) {
    std::ostringstream os;
    os << "ContactDetectorSettings: touchdown_force = " << s.touchdown_force
       << ", takeoff_force = " << s.takeoff_force
       << ", expected touchdown_force > takeoff_force >= 0 and min_phase_time >= 0";
    throw InvalidArgument(os.str());
  }
}

void ContactPhaseDetector::Reset(int mode, const HopperMapping& map, const mjData* d,
                                 const VsaState& vsa) {
  mode_ = mode;
  last_event_time_ = -1e300;
  prev_time_ = d->time;
  MapFlightState(map, d, vsa, prev_flight_.data());
  MapStanceState(map, d, vsa, prev_stance_.data());
  prev_foot_ = FootPosition(map, d);
  normal_force_ = 0.0;
}

bool ContactPhaseDetector::Update(const HopperMapping& map, const mjModel* m, const mjData* d,
                                  const VsaState& vsa) {
  // The force belongs to the forward pass at the previous state (time prev_time_).
  normal_force_ = FootNormalForce(map, m, d);
  bool fired = false;
  const bool settled = prev_time_ - last_event_time_ >= s_.min_phase_time;
  if (settled && mode_ == hopper::kFlight && normal_force_ > s_.touchdown_force) {
    event_.type = ContactEvent::Type::kTouchdown;
    event_.time = prev_time_;
    event_.flight = prev_flight_;
    MapStanceState(map, d, vsa, event_.stance.data());
    event_.foot = prev_foot_;
    event_.normal_force = normal_force_;
    mode_ = hopper::kStance;
    fired = true;
  } else if (settled && mode_ == hopper::kStance && normal_force_ < s_.takeoff_force) {
    event_.type = ContactEvent::Type::kTakeoff;
    event_.time = prev_time_;
    event_.stance = prev_stance_;
    MapFlightState(map, d, vsa, event_.flight.data());
    event_.foot = prev_foot_;
    event_.normal_force = normal_force_;
    mode_ = hopper::kFlight;
    fired = true;
  }
  if (fired) last_event_time_ = prev_time_;
  prev_time_ = d->time;
  MapFlightState(map, d, vsa, prev_flight_.data());
  MapStanceState(map, d, vsa, prev_stance_.data());
  prev_foot_ = FootPosition(map, d);
  return fired;
}

HopperSim::HopperSim(const std::string& mjcf_path, const HopperSimSettings& settings)
    : path_(mjcf_path),
      model_(LoadMjcf(mjcf_path)),
      data_(mj_makeData(model_.get())),
      map_(HopperMapping::Build(model_.get(), mjcf_path)),
      vsa_(map_.beta),
      detector_(settings.detector) {
  HopperParamsFromModel(model_.get(), mjcf_path);  // validates masses and inertias
  detector_.Reset(hopper::kFlight, map_, data_.get(), vsa_.state());
}

void HopperSim::SetFlightState(const Eigen::Matrix<double, 14, 1>& x, double t) {
  if (!x.allFinite()) throw InvalidArgument("HopperSim::SetFlightState: x is not finite");
  mj_resetData(model_.get(), data_.get());
  VsaState v;
  WriteFlightState(map_, x.data(), data_.get(), &v);
  vsa_.Reset(v);
  data_->time = t;
  mj_forward(model_.get(), data_.get());
  detector_.Reset(hopper::kFlight, map_, data_.get(), vsa_.state());
}

void HopperSim::SetStanceState(const Eigen::Matrix<double, 10, 1>& x, double foot_x, double t) {
  if (!x.allFinite()) throw InvalidArgument("HopperSim::SetStanceState: x is not finite");
  mj_resetData(model_.get(), data_.get());
  VsaState v;
  WriteStanceState(map_, x.data(), foot_x, data_.get(), &v);
  vsa_.Reset(v);
  data_->time = t;
  mj_forward(model_.get(), data_.get());
  detector_.Reset(hopper::kStance, map_, data_.get(), vsa_.state());
}

double HopperSim::PushForce(double t) const {
  double f = 0.0;
  for (const Push& p : pushes_) {
    if (t >= p.start && t < p.start + p.duration) f += p.force_x;
  }
  return f;
}

bool HopperSim::Step(const Eigen::Vector4d& u) {
  if (!u.allFinite()) throw InvalidArgument("HopperSim::Step: u is not finite");
  mjData* d = data_.get();
  actuation_ = WriteActuation(map_, model_.get(), d, vsa_.state(), u.data());
  ApplyDragAndPush(map_, model_.get(), d, PushForce(d->time));
  mj_step(model_.get(), d);
  vsa_.Advance(model_->opt.timestep, u(2), u(3));
  const bool fired = detector_.Update(map_, model_.get(), d, vsa_.state());
  if (fired) events_.push_back(detector_.event());
  return fired;
}

Eigen::VectorXd HopperSim::State() const {
  if (mode() == hopper::kFlight) return Flight();
  return Stance();
}

}  // namespace ddoc
