// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/mujoco/contact_phase.h"

#include <cmath>
#include <sstream>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc {

bool FootTouchesFloor(const HopperMapping& map, const mjData* d, double distance) {
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool pair = (c.geom1 == map.geom_foot && c.geom2 == map.geom_floor) ||
                      (c.geom2 == map.geom_foot && c.geom1 == map.geom_floor);
    if (pair && c.dist < distance) return true;
  }
  return false;
}

ContactPhaseDetector::ContactPhaseDetector(const ContactPhaseSettings& s) : settings_(s) {
  auto check = [](bool ok, const char* field, double value, const char* expected) {
    if (ok) return;
    std::ostringstream os;
    os << "ContactPhaseSettings: " << field << " = " << value << ", expected " << expected;
    throw InvalidArgument(os.str());
  };
  check(std::isfinite(s.touchdown_distance), "touchdown_distance", s.touchdown_distance,
        "a finite number");
  check(s.takeoff_force >= 0.0 && std::isfinite(s.takeoff_force), "takeoff_force",
        s.takeoff_force, "finite and >= 0");
  check(s.min_phase_time >= 0.0 && std::isfinite(s.min_phase_time), "min_phase_time",
        s.min_phase_time, "finite and >= 0");
  Reset(hopper::kFlight, -1e9);
}

void ContactPhaseDetector::Reset(int mode, double time) {
  mode_ = mode;
  last_event_ = time;
}

ContactChange ContactPhaseDetector::Update(const HopperMapping& map, const mjData* d) {
  const double t = d->time;
  if (t - last_event_ < settings_.min_phase_time) return ContactChange::kNone;
  if (mode_ == hopper::kFlight) {
    if (!FootTouchesFloor(map, d, settings_.touchdown_distance)) return ContactChange::kNone;
    mode_ = hopper::kStance;
    last_event_ = t;
    return ContactChange::kTouchdown;
  }
  if (!(d->qfrc_constraint[map.dof_z] < settings_.takeoff_force)) return ContactChange::kNone;
  mode_ = hopper::kFlight;
  last_event_ = t;
  return ContactChange::kTakeoff;
}

}  // namespace ddoc
