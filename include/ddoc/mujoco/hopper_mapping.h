// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The ONE mapping between the MJCF hopper (models/hopper*.xml) and the analytic model's
// coordinates, usable on a raw (const mjModel*, mjData*) pair, e.g. inside mjcb_control.
// All functions here are allocation-free.
//
//   paper   MuJoCo
//   x       qpos[x]     + body_pos[torso].x    (joint "x", slide along world x)
//   y       qpos[z]     + body_pos[torso].z    (joint "z", slide along world z)
//   phi     qpos[pitch]                        (hinge about -y: counter-clockwise positive)
//   theta   qpos[pitch] + qpos[hip]            (hinge "hip" about -y measures theta - phi)
//   r       r0 + qpos[leg]                     (slide "leg" along the leg, away from the hip)
//   rates   the same sums of qvel
//   k_hip, k_leg and rates: the VSA states kept beside MuJoCo (ddoc::VsaState)
//
// Flight state (14): [x, y, theta, phi, r, k_hip, k_leg, xd, yd, thetad, phid, rd, k_hipd, k_legd]
// Stance state (10): [theta, phi, r, k_hip, k_leg, thetad, phid, rd, k_hipd, k_legd]
// (x, y) is the hip = the COM of the body; the foot is the centre of the foot sphere,
// (x, y) + r (sin theta, -cos theta); the floor surface is at foot-centre height 0.
#ifndef DDOC_MUJOCO_HOPPER_MAPPING_H_
#define DDOC_MUJOCO_HOPPER_MAPPING_H_

#include <string>

#include <Eigen/Dense>
#include <mujoco/mujoco.h>

#include "ddoc/hopper/vsa.h"
#include "ddoc/switched_system.h"

namespace ddoc {

/// Error in an MJCF hopper: the message names the file and the element.
class HopperSimError : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

/// Names the harness looks up in the MJCF.
struct HopperNames {
  const char* torso = "torso";       ///< body: mass M, inertia J_body, joints x, z, pitch
  const char* leg = "leg";           ///< body: inertia J_leg, joint hip
  const char* foot = "foot";         ///< body (joint leg) and its sphere geom
  const char* joint_x = "x";         ///< slide along world x
  const char* joint_z = "z";         ///< slide along world z
  const char* joint_pitch = "pitch"; ///< hinge about -y
  const char* joint_hip = "hip";     ///< hinge about -y (theta - phi)
  const char* joint_leg = "leg";     ///< slide along the leg (r - r0)
  const char* hip_motor = "hip_motor";  ///< motor on hip, gear -1, ctrl = tau_hip
  const char* leg_motor = "leg_motor";  ///< motor on leg, gear +1, ctrl = F_leg
  const char* foot_geom = "foot";       ///< sphere
  const char* floor_geom = "floor";     ///< plane
  const char* drag = "drag_cd";         ///< <custom><numeric>: c_d (kg/m), optional (0)
  const char* beta = "vsa_beta";        ///< <custom><numeric>: beta (rad/s), optional (20)
};

/// Indices resolved once from an mjModel by name (see HopperNames), plus r0 and the custom
/// numerics. Build() throws HopperSimError naming `source` (the file) and the element.
struct HopperMapping {
  int body_torso = -1, body_leg = -1, body_foot = -1;
  int qpos_x = -1, qpos_z = -1, qpos_pitch = -1, qpos_hip = -1, qpos_leg = -1;  // qpos addresses
  int dof_x = -1, dof_z = -1, dof_pitch = -1, dof_hip = -1, dof_leg = -1;       // qvel addresses
  int act_hip = -1, act_leg = -1;     // actuator ids (ctrl indices)
  int geom_foot = -1, geom_floor = -1;
  double x_offset = 0.0;   ///< body_pos[torso].x: x = qpos[x] + x_offset
  double y_offset = 0.0;   ///< body_pos[torso].z: y = qpos[z] + y_offset
  double r0 = 0.7;         ///< natural leg length: distance hip -> foot body at qpos[leg] = 0
  double drag_cd = 0.0;    ///< c_d from <numeric name="drag_cd">, kg/m
  double beta = kDefaultVsaBeta;  ///< from <numeric name="vsa_beta">, rad/s
  double leg_damping = 0.0;  ///< damping of joint "leg" (dof_damping), N s/m: HopperParams::b_leg
  double hip_damping = 0.0;  ///< damping of joint "hip" (dof_damping), N m s/rad: HopperParams::b_hip
  /// Floor slope alpha, rad (HopperParams::slope): the plane "floor" turned about y, normal
  /// (-sin alpha, 0, cos alpha); alpha > 0 rises towards +x. A tilted floor must put the
  /// foot-centre surface through the origin (plane pos = foot radius * (sin alpha, 0, -cos alpha)).
  double floor_slope = 0.0;
  double timestep = 0.0;   ///< m->opt.timestep

  static HopperMapping Build(const mjModel* m, const std::string& source = "<mjModel>",
                             const HopperNames& names = HopperNames());
};

/// For an MJCF that is simulated as the robot (not one only read for the model's numbers): the
/// VSA springs enter as ctrl held over each step (explicit), so a spring of stiffness k on its
/// joint's effective inertia I (1 / (M^-1)_jj at qpos0, the other joints free) grows once
/// sqrt(k / I) * timestep >= 2. Throws HopperSimError naming the joint, the ratio and the largest
/// stable timestep for the leg (k_leg up to 2350 N/m on the foot) and the hip (k_hip up to
/// 150 N m/rad). Likewise for a joint damping b on "leg" or "hip" once b * timestep / I >= 1.5
/// (the foot chatters on the floor; the leg's I is the 2 g foot: b_leg < 6 N s/m at 0.5 ms).
void CheckSpringsAreStableAtTheTimestep(const mjModel* m, const HopperMapping& map,
                                        const std::string& source);

/// Flight state (14, see file comment) from d and the VSA states. x must point to 14 doubles.
void MapFlightState(const HopperMapping& map, const mjData* d, const VsaState& vsa, double* x);
/// Stance state (10) from d and the VSA states. x must point to 10 doubles.
void MapStanceState(const HopperMapping& map, const mjData* d, const VsaState& vsa, double* x);
/// Eigen conveniences of the two above.
Eigen::Matrix<double, 14, 1> FlightState(const HopperMapping& map, const mjData* d,
                                         const VsaState& vsa);
Eigen::Matrix<double, 10, 1> StanceState(const HopperMapping& map, const mjData* d,
                                         const VsaState& vsa);
/// Foot-centre position (x_f, y_f) from qpos: (x + r sin theta, y - r cos theta).
Eigen::Vector2d FootPosition(const HopperMapping& map, const mjData* d);

/// Writes qpos/qvel from a flight state (14); the VSA part is returned in *vsa (may be null).
void WriteFlightState(const HopperMapping& map, const double* x, mjData* d, VsaState* vsa);
/// Writes qpos/qvel from a stance state (10) with the foot centre on the floor at foot_x, i.e. at
/// (foot_x, foot_x tan(floor_slope)): x = foot_x - r sin theta, y = foot_x tan(floor_slope) +
/// r cos theta, xd = -rd sin th - r thd cos th,
/// yd = rd cos th - r thd sin th (the foot at rest).
void WriteStanceState(const HopperMapping& map, const double* x, double foot_x, mjData* d,
                      VsaState* vsa);

/// The actuator outputs of the VSA law.
struct HopperActuation {
  double tau_hip = 0.0;  ///< tau0 - k_hip (phi - theta), N m (+ on the body, - on the leg)
  double f_leg = 0.0;    ///< F0 - k_leg (r - r0), N (+ extends the leg)
};

/// Computes tau_hip and F_leg from u = [tau0, F0, k0_hip, k0_leg] (only u[0], u[1] enter; the
/// stiffnesses are the current VSA states) and writes them into d->ctrl. u must point to 4
/// doubles. Call before mj_step (or inside mjcb_control).
HopperActuation WriteActuation(const HopperMapping& map, const mjModel* m, mjData* d,
                               const VsaState& vsa, const double* u);

/// Air drag F = -c_d (xd|xd|, 0, yd|yd|) on the torso COM (per component, eq. (38)) plus a
/// horizontal push force_x, written (not added) into d->xfrc_applied of the torso. Usable inside
/// mjcb_control (MuJoCo reads xfrc_applied after the control callback).
void ApplyDragAndPush(const HopperMapping& map, const mjModel* m, mjData* d, double push_x);

/// Sum of the normal forces of all foot-floor contacts (N, >= 0). Valid after mj_step or
/// mj_forward (it reads d->efc_force of the last forward pass); NOT inside mjcb_control, where
/// the constraint forces of the current step are not solved yet.
double FootNormalForce(const HopperMapping& map, const mjModel* m, const mjData* d);

}  // namespace ddoc

#endif  // DDOC_MUJOCO_HOPPER_MAPPING_H_
