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
  p.b_leg = map.leg_damping;
  p.b_hip = map.hip_damping;
  p.slope = map.floor_slope;
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

HopperSim::HopperSim(const std::string& mjcf_path, const HopperSimSettings& settings)
    : path_(mjcf_path),
      model_(LoadMjcf(mjcf_path)),
      data_(mj_makeData(model_.get())),
      map_(HopperMapping::Build(model_.get(), mjcf_path)),
      vsa_(map_.beta),
      detector_(settings.contact) {
  HopperParamsFromModel(model_.get(), mjcf_path);  // validates masses and inertias
  CheckSpringsAreStableAtTheTimestep(model_.get(), map_, mjcf_path);
}

void HopperSim::SetFlightState(const Eigen::Matrix<double, 14, 1>& x, double t) {
  if (!x.allFinite()) throw InvalidArgument("HopperSim::SetFlightState: x is not finite");
  mj_resetData(model_.get(), data_.get());
  VsaState v;
  WriteFlightState(map_, x.data(), data_.get(), &v);
  vsa_.Reset(v);
  data_->time = t;
  mj_forward(model_.get(), data_.get());
  detector_.Reset(hopper::kFlight, t);
  stance_now_ = stance_before_ = Stance();
}

void HopperSim::SetStanceState(const Eigen::Matrix<double, 10, 1>& x, double foot_x, double t) {
  if (!x.allFinite()) throw InvalidArgument("HopperSim::SetStanceState: x is not finite");
  mj_resetData(model_.get(), data_.get());
  VsaState v;
  WriteStanceState(map_, x.data(), foot_x, data_.get(), &v);
  vsa_.Reset(v);
  data_->time = t;
  mj_forward(model_.get(), data_.get());
  detector_.Reset(hopper::kStance, t);
  stance_now_ = stance_before_ = Stance();
}

bool HopperSim::Step(const Eigen::Vector4d& u) {
  if (!u.allFinite()) throw InvalidArgument("HopperSim::Step: u is not finite");
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  mj_step1(m, d);  // the collision pass of the current state, as mjcb_control sees it
  const ContactChange change = detector_.Update(map_, d);
  if (change != ContactChange::kNone) {
    ContactEvent e;
    e.type = change == ContactChange::kTouchdown ? ContactEvent::Type::kTouchdown
                                                 : ContactEvent::Type::kTakeoff;
    e.time = d->time;
    e.flight = Flight();
    e.stance = stance_before_;  // takeoff: the last stance state (touchdown: filled below)
    e.foot = Foot();
    events_.push_back(e);
  }
  actuation_ = WriteActuation(map_, m, d, vsa_.state(), u.data());
  ApplyDragAndPush(map_, m, d, PushForce(d->time));
  mj_step2(m, d);
  vsa_.Advance(m->opt.timestep, u(2), u(3));
  stance_before_ = stance_now_;
  stance_now_ = Stance();
  if (change == ContactChange::kTouchdown) events_.back().stance = stance_now_;
  return change != ContactChange::kNone;
}

Eigen::VectorXd HopperSim::State() const {
  if (mode() == hopper::kFlight) return Flight();
  return Stance();
}

}  // namespace ddoc
