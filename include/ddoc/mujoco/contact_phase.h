// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The one contact-phase detector of ddoc: flight / stance of the MJCF hopper from mjData.
#ifndef DDOC_MUJOCO_CONTACT_PHASE_H_
#define DDOC_MUJOCO_CONTACT_PHASE_H_

#include <mujoco/mujoco.h>

#include "ddoc/mujoco/hopper_mapping.h"

namespace ddoc {

/// Settings of ContactPhaseDetector.
struct ContactPhaseSettings {
  /// Touchdown: a foot-floor contact of the current collision pass with distance below this, m.
  double touchdown_distance = 0.0;
  /// Takeoff: the floor's vertical force on the robot (last constraint solve) below this, N.
  double takeoff_force = 0.5;
  /// No phase change within this time after the previous one (or after Reset), s.
  double min_phase_time = 0.03;
  /// Events located inside the physics step (event_time(), class comment); default false.
  bool substep_events = false;
};

/// What one Update found.
enum class ContactChange { kNone, kTouchdown, kTakeoff };

/// Flight / stance of the hopper, used by the plugin, HopperSim (and so ddoc-drop) and the tests.
/// Update() must be called once per physics step where mjData holds the collision pass of the
/// current state and still the constraint forces of the previous step: inside mjcb_control, or
/// between mj_step1 and mj_step2. Then:
///   - touchdown (flight -> stance): the current collision pass has a foot-floor contact closer
///     than touchdown_distance. The current state is the last one before the impact, x^-(T1).
///   - takeoff (stance -> flight): qfrc_constraint of the torso's vertical slide (the floor's
///     vertical force on the robot, solved in the previous step) fell below takeoff_force. The
///     current state is the first state of the flight.
///   - min_phase_time after an event no new one: it rejects the one-step bounce MuJoCo shows at
///     some impacts.
/// With substep_events, event_time() locates the event inside the step (linear in the signal
/// between the two samples that bracket its threshold):
///   - touchdown in (t_prev, t]: where the foot-floor distance crossed touchdown_distance. The
///     distance is the contact's dist now and dist + the foot centre's move along the floor's
///     normal before (a sphere on a plane, any slope); the semi-implicit Euler step moves the
///     positions linearly over the step, so this is the crossing of the simulated path.
///   - takeoff in [t_prev2, t_prev]: where the floor's vertical force crossed takeoff_force. The
///     force read at a step was solved from the previous step's state: it is located there.
/// Allocation-free.
class ContactPhaseDetector {
 public:
  /// Throws InvalidArgument naming the field when a setting is not finite or
  /// takeoff_force < 0 or min_phase_time < 0.
  explicit ContactPhaseDetector(const ContactPhaseSettings& settings = {});

  /// Starts in `mode` (hopper::kFlight or kStance) as if the last event had happened at `time`.
  void Reset(int mode, double time);
  /// Detects the phase of the current step at time d->time (see the class comment).
  ContactChange Update(const HopperMapping& map, const mjData* d);

  int mode() const { return mode_; }
  /// The step time of the last event (d->time of the Update that found it), s.
  double last_event_time() const { return last_event_; }
  /// The instant of the last event, s: last_event_time() without substep_events, else the
  /// sub-step estimate (see the class comment; the step time when the detector has no samples
  /// from before the event, e.g. right after Reset).
  double event_time() const { return event_time_; }
  const ContactPhaseSettings& settings() const { return settings_; }

 private:
  ContactPhaseSettings settings_;
  int mode_ = 0;              // hopper::kFlight / kStance
  double last_event_ = -1e9;  // s
  double event_time_ = -1e9;  // s
  // substep_events: the previous Updates' times (t_prev, t_prev2), the foot centre's height along
  // the floor's normal at t_prev, the vertical force read at t_prev, and how many are valid.
  double time_prev_ = 0.0, time_prev2_ = 0.0;
  double height_prev_ = 0.0, force_prev_ = 0.0;
  int history_ = 0;
  // The step-time detection (the class comment); sets mode_, last_event_ and event_time_.
  ContactChange Detect(const HopperMapping& map, const mjData* d);
  // Sets event_time_ for the event `change` just found at d->time (substep_events).
  void LocateEvent(const HopperMapping& map, const mjData* d, ContactChange change);
  // Remembers this Update's samples (substep_events).
  void Remember(const HopperMapping& map, const mjData* d);
};

/// True when the current collision pass of d has a contact between the foot and the floor geoms
/// with distance below `distance` (m).
bool FootTouchesFloor(const HopperMapping& map, const mjData* d, double distance);

}  // namespace ddoc

#endif  // DDOC_MUJOCO_CONTACT_PHASE_H_
