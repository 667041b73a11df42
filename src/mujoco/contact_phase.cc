// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/mujoco/contact_phase.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc {
namespace {

// The foot centre's height along the floor's normal (the plane's z axis), m.
double FootNormalHeight(const HopperMapping& map, const mjData* d) {
  const double* n = d->geom_xmat + 9 * map.geom_floor;  // row-major: column 2 is 2, 5, 8
  const double* c = d->geom_xpos + 3 * map.geom_foot;
  return n[2] * c[0] + n[5] * c[1] + n[8] * c[2];
}

bool IsFootFloor(const HopperMapping& map, const mjContact& c) {
  return (c.geom1 == map.geom_foot && c.geom2 == map.geom_floor) ||
         (c.geom2 == map.geom_foot && c.geom1 == map.geom_floor);
}

// The smallest distance of the foot-floor contacts of the current collision pass, or +inf.
double FootFloorDistance(const HopperMapping& map, const mjData* d) {
  double dist = std::numeric_limits<double>::infinity();
  for (int i = 0; i < d->ncon; ++i) {
    if (IsFootFloor(map, d->contact[i])) dist = std::min(dist, d->contact[i].dist);
  }
  return dist;
}

// The fraction in [0, 1] at which a signal going from a to b crosses `level`; 1 when it does not
// move towards it.
double Crossing(double a, double b, double level) {
  if (!(a != b)) return 1.0;
  return std::min(1.0, std::max(0.0, (a - level) / (a - b)));
}

}  // namespace

bool FootTouchesFloor(const HopperMapping& map, const mjData* d, double distance) {
  return FootFloorDistance(map, d) < distance;
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
  event_time_ = time;
  history_ = 0;
}

ContactChange ContactPhaseDetector::Update(const HopperMapping& map, const mjData* d) {
  const ContactChange change = Detect(map, d);
  if (settings_.substep_events) {
    if (change != ContactChange::kNone) LocateEvent(map, d, change);
    Remember(map, d);
  }
  return change;
}

ContactChange ContactPhaseDetector::Detect(const HopperMapping& map, const mjData* d) {
  const double t = d->time;
  if (t - last_event_ < settings_.min_phase_time) return ContactChange::kNone;
  if (mode_ == hopper::kFlight) {
    if (!FootTouchesFloor(map, d, settings_.touchdown_distance)) return ContactChange::kNone;
    mode_ = hopper::kStance;
    last_event_ = event_time_ = t;
    return ContactChange::kTouchdown;
  }
  if (!(d->qfrc_constraint[map.dof_z] < settings_.takeoff_force)) return ContactChange::kNone;
  mode_ = hopper::kFlight;
  last_event_ = event_time_ = t;
  return ContactChange::kTakeoff;
}

void ContactPhaseDetector::LocateEvent(const HopperMapping& map, const mjData* d,
                                       ContactChange change) {
  const double t = d->time;
  if (change == ContactChange::kTouchdown && history_ >= 1 && t > time_prev_) {
    // The distance now, and before: the same plus the foot centre's move along the normal.
    const double now = FootFloorDistance(map, d);
    const double before = now + (height_prev_ - FootNormalHeight(map, d));
    const double w = Crossing(before, now, settings_.touchdown_distance);
    event_time_ = time_prev_ + w * (t - time_prev_);
  } else if (change == ContactChange::kTakeoff && history_ >= 2 && time_prev_ > time_prev2_) {
    // The force read now was solved at t_prev, the one read at t_prev at t_prev2.
    const double w = Crossing(force_prev_, d->qfrc_constraint[map.dof_z], settings_.takeoff_force);
    event_time_ = time_prev2_ + w * (time_prev_ - time_prev2_);
  }
}

void ContactPhaseDetector::Remember(const HopperMapping& map, const mjData* d) {
  time_prev2_ = time_prev_;
  time_prev_ = d->time;
  height_prev_ = FootNormalHeight(map, d);
  force_prev_ = d->qfrc_constraint[map.dof_z];
  history_ = std::min(history_ + 1, 2);
}

}  // namespace ddoc
