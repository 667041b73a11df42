// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/mujoco/hopper_mapping.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "ddoc/hopper/hopper_model.h"
#include "ddoc/mujoco/hopper_sim.h"

namespace ddoc {

namespace {

[[noreturn]] void Fail(const std::string& source, const std::string& what) {
  throw HopperSimError("hopper MJCF '" + source + "': " + what);
}

int FindId(const mjModel* m, mjtObj type, const char* name, const char* kind,
           const std::string& source, const char* hint) {
  const int id = mj_name2id(m, type, name);
  if (id < 0) {
    Fail(source, std::string("no ") + kind + " named '" + name + "' (" + hint + ")");
  }
  return id;
}

int FindJoint(const mjModel* m, const char* name, int type, int body, const std::string& source,
              const char* hint) {
  const int id = FindId(m, mjOBJ_JOINT, name, "joint", source, hint);
  if (m->jnt_type[id] != type) {
    Fail(source, std::string("joint '") + name + "' has the wrong type (" + hint + ")");
  }
  if (m->jnt_bodyid[id] != body) {
    Fail(source, std::string("joint '") + name + "' is in body '" +
                     mj_id2name(m, mjOBJ_BODY, m->jnt_bodyid[id]) + "' (" + hint + ")");
  }
  return id;
}

void CheckAxis(const mjModel* m, int jnt, double ax, double ay, double az,
               const std::string& source, const char* name) {
  const mjtNum* a = m->jnt_axis + 3 * jnt;
  if (std::abs(a[0] - ax) > 1e-9 || std::abs(a[1] - ay) > 1e-9 || std::abs(a[2] - az) > 1e-9) {
    std::ostringstream os;
    os << "joint '" << name << "' has axis (" << a[0] << " " << a[1] << " " << a[2]
       << "), expected (" << ax << " " << ay << " " << az << ")";
    Fail(source, os.str());
  }
}

double Numeric(const mjModel* m, const char* name, double fallback, const std::string& source) {
  const int id = mj_name2id(m, mjOBJ_NUMERIC, name);
  if (id < 0) return fallback;
  if (m->numeric_size[id] < 1) Fail(source, std::string("<numeric name='") + name + "'> is empty");
  const double v = m->numeric_data[m->numeric_adr[id]];
  if (!std::isfinite(v)) Fail(source, std::string("<numeric name='") + name + "'> is not finite");
  return v;
}

}  // namespace

HopperMapping HopperMapping::Build(const mjModel* m, const std::string& source,
                                   const HopperNames& n) {
  if (!m) throw HopperSimError("HopperMapping::Build: null mjModel (" + source + ")");
  HopperMapping map;
  map.body_torso = FindId(m, mjOBJ_BODY, n.torso, "body", source, "the hopper's main body");
  map.body_leg = FindId(m, mjOBJ_BODY, n.leg, "body", source, "the leg, child of the torso");
  map.body_foot = FindId(m, mjOBJ_BODY, n.foot, "body", source, "the foot, child of the leg");
  if (m->body_parentid[map.body_leg] != map.body_torso ||
      m->body_parentid[map.body_foot] != map.body_leg) {
    Fail(source, "expected the body chain torso -> leg -> foot");
  }
  const int jx = FindJoint(m, n.joint_x, mjJNT_SLIDE, map.body_torso, source,
                           "slide joint along x in body 'torso'");
  const int jz = FindJoint(m, n.joint_z, mjJNT_SLIDE, map.body_torso, source,
                           "slide joint along z in body 'torso'");
  const int jp = FindJoint(m, n.joint_pitch, mjJNT_HINGE, map.body_torso, source,
                           "hinge joint about -y in body 'torso'");
  const int jh = FindJoint(m, n.joint_hip, mjJNT_HINGE, map.body_leg, source,
                           "hinge joint about -y in body 'leg'");
  const int jl = FindJoint(m, n.joint_leg, mjJNT_SLIDE, map.body_foot, source,
                           "slide joint along the leg in body 'foot'");
  CheckAxis(m, jx, 1, 0, 0, source, n.joint_x);
  CheckAxis(m, jz, 0, 0, 1, source, n.joint_z);
  CheckAxis(m, jp, 0, -1, 0, source, n.joint_pitch);
  CheckAxis(m, jh, 0, -1, 0, source, n.joint_hip);
  CheckAxis(m, jl, 0, 0, -1, source, n.joint_leg);
  map.qpos_x = m->jnt_qposadr[jx];
  map.qpos_z = m->jnt_qposadr[jz];
  map.qpos_pitch = m->jnt_qposadr[jp];
  map.qpos_hip = m->jnt_qposadr[jh];
  map.qpos_leg = m->jnt_qposadr[jl];
  map.dof_x = m->jnt_dofadr[jx];
  map.dof_z = m->jnt_dofadr[jz];
  map.dof_pitch = m->jnt_dofadr[jp];
  map.dof_hip = m->jnt_dofadr[jh];
  map.dof_leg = m->jnt_dofadr[jl];
  if (m->body_parentid[map.body_torso] != 0) Fail(source, "body 'torso' must be a child of world");
  map.x_offset = m->body_pos[3 * map.body_torso + 0];
  map.y_offset = m->body_pos[3 * map.body_torso + 2];
  // The leg body sits at the hip; the foot body straight below it at distance r0.
  const mjtNum* lp = m->body_pos + 3 * map.body_leg;
  const mjtNum* fp = m->body_pos + 3 * map.body_foot;
  if (std::abs(lp[0]) + std::abs(lp[1]) + std::abs(lp[2]) > 1e-12) {
    Fail(source, "body 'leg' must be at the torso origin (pos=\"0 0 0\"), the hip");
  }
  if (std::abs(fp[0]) + std::abs(fp[1]) > 1e-12 || !(fp[2] < 0.0)) {
    Fail(source, "body 'foot' must be straight below the hip (pos=\"0 0 -r0\", r0 > 0)");
  }
  map.r0 = -fp[2];
  // Actuators: motors on the two VSA joints with the documented gears.
  map.act_hip = FindId(m, mjOBJ_ACTUATOR, n.hip_motor, "actuator", source,
                       "motor on joint 'hip' with gear -1");
  map.act_leg = FindId(m, mjOBJ_ACTUATOR, n.leg_motor, "actuator", source,
                       "motor on joint 'leg' with gear 1");
  if (m->actuator_trntype[map.act_hip] != mjTRN_JOINT || m->actuator_trnid[2 * map.act_hip] != jh ||
      std::abs(m->actuator_gear[6 * map.act_hip] + 1.0) > 1e-12) {
    Fail(source, std::string("actuator '") + n.hip_motor + "' must act on joint 'hip' with gear -1");
  }
  if (m->actuator_trntype[map.act_leg] != mjTRN_JOINT || m->actuator_trnid[2 * map.act_leg] != jl ||
      std::abs(m->actuator_gear[6 * map.act_leg] - 1.0) > 1e-12) {
    Fail(source, std::string("actuator '") + n.leg_motor + "' must act on joint 'leg' with gear 1");
  }
  for (int a : {map.act_hip, map.act_leg}) {
    if (m->actuator_ctrllimited[a] || m->actuator_forcelimited[a]) {
      Fail(source, std::string("actuator '") + mj_id2name(m, mjOBJ_ACTUATOR, a) +
                       "' must not be ctrl/force limited (the bounds apply to u, not to the "
                       "spring forces)");
    }
  }
  map.geom_foot = FindId(m, mjOBJ_GEOM, n.foot_geom, "geom", source, "the foot sphere");
  map.geom_floor = FindId(m, mjOBJ_GEOM, n.floor_geom, "geom", source, "the floor plane");
  if (m->geom_bodyid[map.geom_foot] != map.body_foot) {
    Fail(source, "geom 'foot' must belong to body 'foot'");
  }
  // The floor: a plane of the world body, level or turned about y only (the plane of motion is
  // x-z). Its normal n = R (0, 0, 1) = (-sin alpha, 0, cos alpha).
  if (m->geom_type[map.geom_floor] != mjGEOM_PLANE || m->geom_bodyid[map.geom_floor] != 0) {
    Fail(source, "geom 'floor' must be a plane of the worldbody");
  }
  {
    const mjtNum* fq = m->geom_quat + 4 * map.geom_floor;
    mjtNum normal[3];
    const mjtNum up[3] = {0.0, 0.0, 1.0};
    mju_rotVecQuat(normal, up, fq);
    if (std::abs(normal[1]) > 1e-9 || !(normal[2] > 0.0)) {
      std::ostringstream os;
      os << "geom 'floor' has normal (" << normal[0] << " " << normal[1] << " " << normal[2]
         << "), expected (-sin alpha, 0, cos alpha) with cos alpha > 0: a floor turned about y only";
      Fail(source, os.str());
    }
    map.floor_slope = std::atan2(-normal[0], normal[2]);
    if (map.floor_slope != 0.0) {
      // The model's floor line passes through the origin: the foot-centre surface, the plane
      // moved out by the foot radius, must contain (0, 0, 0).
      const mjtNum* fp = m->geom_pos + 3 * map.geom_floor;
      const double radius = m->geom_size[3 * map.geom_foot];
      const double offset = -(normal[0] * fp[0] + normal[1] * fp[1] + normal[2] * fp[2]) - radius;
      if (std::abs(offset) > 1e-6) {
        std::ostringstream os;
        os << "the tilted geom 'floor' (slope " << map.floor_slope << " rad) puts the foot-centre "
           << "surface " << offset << " m from the origin, expected 0 (pos = foot radius * (sin "
           << "alpha, 0, -cos alpha) = (" << radius * std::sin(map.floor_slope) << " 0 "
           << -radius * std::cos(map.floor_slope) << "))";
        Fail(source, os.str());
      }
    }
  }
  map.leg_damping = m->dof_damping[map.dof_leg];
  map.hip_damping = m->dof_damping[map.dof_hip];
  // Masses and inertias (MuJoCo's compiler already rejects most, but name them clearly).
  for (int b : {map.body_torso, map.body_leg, map.body_foot}) {
    const char* bn = mj_id2name(m, mjOBJ_BODY, b);
    if (!(m->body_mass[b] > 0.0)) {
      std::ostringstream os;
      os << "body '" << bn << "' has mass " << m->body_mass[b] << ", expected > 0";
      Fail(source, os.str());
    }
    for (int i = 0; i < 3; ++i) {
      if (!(m->body_inertia[3 * b + i] > 0.0)) {
        std::ostringstream os;
        os << "body '" << bn << "' has inertia component " << i << " = "
           << m->body_inertia[3 * b + i] << ", expected > 0";
        Fail(source, os.str());
      }
    }
  }
  // A <numeric> the hopper does not read is a typo (drag_c for drag_cd would silently mean no
  // drag): an error naming it.
  for (int i = 0; i < m->nnumeric; ++i) {
    const char* name = mj_id2name(m, mjOBJ_NUMERIC, i);
    const std::string s = name != nullptr ? name : "";
    if (s != n.drag && s != n.beta) {
      Fail(source, "unknown <numeric name='" + s + "'> (the hopper reads '" + n.drag + "' and '" +
                       n.beta + "')");
    }
    if (m->numeric_size[i] != 1) {
      Fail(source, "<numeric name='" + s + "'> has " + std::to_string(m->numeric_size[i]) +
                       " values, expected 1");
    }
  }
  map.drag_cd = Numeric(m, n.drag, 0.0, source);
  if (map.drag_cd < 0.0) Fail(source, "<numeric name='drag_cd'> must be >= 0");
  map.beta = Numeric(m, n.beta, kDefaultVsaBeta, source);
  if (!(map.beta > 0.0)) Fail(source, "<numeric name='vsa_beta'> must be > 0");
  map.timestep = m->opt.timestep;
  return map;
}

void CheckSpringsAreStableAtTheTimestep(const mjModel* m, const HopperMapping& map,
                                        const std::string& source) {
  const MjDataPtr d(mj_makeData(m));
  if (!d) Fail(source, "mj_makeData failed");
  mj_fwdPosition(m, d.get());  // the joint-space inertia M at qpos0, factorized
  struct Spring {
    int dof;
    double k_max;
    const char* what;
    const char* inertia_unit;
  };
  const Spring springs[] = {
      {map.dof_leg, hopper::InputUpperBound()(3), "leg spring (k_leg up to 2350 N/m)",
       "effective mass on joint 'leg', kg"},
      {map.dof_hip, hopper::InputUpperBound()(2), "hip spring (k_hip up to 150 N m/rad)",
       "effective inertia on joint 'hip', kg m^2"}};
  std::vector<mjtNum> e(static_cast<size_t>(m->nv)), minv_e(static_cast<size_t>(m->nv));
  for (const Spring& sp : springs) {
    std::fill(e.begin(), e.end(), 0.0);
    e[static_cast<size_t>(sp.dof)] = 1.0;
    mj_solveM(m, d.get(), minv_e.data(), e.data(), 1);
    const double inertia = 1.0 / minv_e[static_cast<size_t>(sp.dof)];  // effective, others free
    const double ratio = std::sqrt(sp.k_max / inertia) * m->opt.timestep;
    if (!(ratio < 2.0)) {
      std::ostringstream os;
      os << "timestep " << m->opt.timestep << " s is too long for the " << sp.what << ": "
         << "sqrt(k / I) * timestep = " << ratio << " with I = " << inertia << " ("
         << sp.inertia_unit << "), and the explicit spring grows from 2 on; use a timestep below "
         << 2.0 * std::sqrt(inertia / sp.k_max) << " s";
      Fail(source, os.str());
    }
  }
  // Joint damping (issue 44's leg and hip dampers), integrated implicitly by MuJoCo's Euler, on a
  // light joint: the contact solver does not see it, and from damping * timestep / I ~ 1.6 on the
  // foot (2 g) chatters on the floor in stance (measured on hopper_damped_leg.xml at 1 m/s:
  // b_leg = 6 N s/m, ratio 1.50, hops; 7 N s/m, ratio 1.75, five false takeoffs in one stance).
  constexpr double kMaxDampingRatio = 1.5;
  for (const Spring& sp : springs) {
    const double b = m->dof_damping[sp.dof];
    if (b == 0.0) continue;
    std::fill(e.begin(), e.end(), 0.0);
    e[static_cast<size_t>(sp.dof)] = 1.0;
    mj_solveM(m, d.get(), minv_e.data(), e.data(), 1);
    const double inertia = 1.0 / minv_e[static_cast<size_t>(sp.dof)];
    const double ratio = b * m->opt.timestep / inertia;
    if (!(ratio < kMaxDampingRatio)) {
      std::ostringstream os;
      os << "damping " << b << " of joint '" << mj_id2name(m, mjOBJ_JOINT, m->dof_jntid[sp.dof])
         << "' is too strong for its " << inertia << " (" << sp.inertia_unit << ") at timestep "
         << m->opt.timestep << " s: damping * timestep / I = " << ratio
         << ", and the foot chatters on the floor from " << kMaxDampingRatio
         << " on; use a damping below " << kMaxDampingRatio * inertia / m->opt.timestep
         << " or a timestep below " << kMaxDampingRatio * inertia / b << " s";
      Fail(source, os.str());
    }
  }
}

void MapFlightState(const HopperMapping& map, const mjData* d, const VsaState& vsa, double* x) {
  const mjtNum* q = d->qpos;
  const mjtNum* v = d->qvel;
  x[0] = q[map.qpos_x] + map.x_offset;
  x[1] = q[map.qpos_z] + map.y_offset;
  x[2] = q[map.qpos_pitch] + q[map.qpos_hip];
  x[3] = q[map.qpos_pitch];
  x[4] = map.r0 + q[map.qpos_leg];
  x[5] = vsa.k_hip;
  x[6] = vsa.k_leg;
  x[7] = v[map.dof_x];
  x[8] = v[map.dof_z];
  x[9] = v[map.dof_pitch] + v[map.dof_hip];
  x[10] = v[map.dof_pitch];
  x[11] = v[map.dof_leg];
  x[12] = vsa.kd_hip;
  x[13] = vsa.kd_leg;
}

void MapStanceState(const HopperMapping& map, const mjData* d, const VsaState& vsa, double* x) {
  double f[14];
  MapFlightState(map, d, vsa, f);
  // Drop x, y and their rates: stance = [theta, phi, r, k_hip, k_leg] and rates.
  for (int i = 0; i < 5; ++i) {
    x[i] = f[2 + i];
    x[5 + i] = f[9 + i];
  }
}

Eigen::Matrix<double, 14, 1> FlightState(const HopperMapping& map, const mjData* d,
                                         const VsaState& vsa) {
  Eigen::Matrix<double, 14, 1> x;
  MapFlightState(map, d, vsa, x.data());
  return x;
}

Eigen::Matrix<double, 10, 1> StanceState(const HopperMapping& map, const mjData* d,
                                         const VsaState& vsa) {
  Eigen::Matrix<double, 10, 1> x;
  MapStanceState(map, d, vsa, x.data());
  return x;
}

Eigen::Vector2d FootPosition(const HopperMapping& map, const mjData* d) {
  const mjtNum* q = d->qpos;
  const double th = q[map.qpos_pitch] + q[map.qpos_hip];
  const double r = map.r0 + q[map.qpos_leg];
  return Eigen::Vector2d(q[map.qpos_x] + map.x_offset + r * std::sin(th),
                         q[map.qpos_z] + map.y_offset - r * std::cos(th));
}

void WriteFlightState(const HopperMapping& map, const double* x, mjData* d, VsaState* vsa) {
  mjtNum* q = d->qpos;
  mjtNum* v = d->qvel;
  q[map.qpos_x] = x[0] - map.x_offset;
  q[map.qpos_z] = x[1] - map.y_offset;
  q[map.qpos_pitch] = x[3];
  q[map.qpos_hip] = x[2] - x[3];
  q[map.qpos_leg] = x[4] - map.r0;
  v[map.dof_x] = x[7];
  v[map.dof_z] = x[8];
  v[map.dof_pitch] = x[10];
  v[map.dof_hip] = x[9] - x[10];
  v[map.dof_leg] = x[11];
  if (vsa) {
    vsa->k_hip = x[5];
    vsa->k_leg = x[6];
    vsa->kd_hip = x[12];
    vsa->kd_leg = x[13];
  }
}

void WriteStanceState(const HopperMapping& map, const double* xs, double foot_x, mjData* d,
                      VsaState* vsa) {
  const double th = xs[0], r = xs[2], thd = xs[5], rd = xs[7];
  const double s = std::sin(th), c = std::cos(th);
  double f[14];
  f[0] = foot_x - r * s;
  f[1] = r * c;
  if (map.floor_slope != 0.0) f[1] += foot_x * std::tan(map.floor_slope);  // foot on the slope
  for (int i = 0; i < 5; ++i) {
    f[2 + i] = xs[i];
    f[9 + i] = xs[5 + i];
  }
  f[7] = -rd * s - r * thd * c;
  f[8] = rd * c - r * thd * s;
  WriteFlightState(map, f, d, vsa);
}

HopperActuation WriteActuation(const HopperMapping& map, const mjModel* m, mjData* d,
                               const VsaState& vsa, const double* u) {
  (void)m;
  const mjtNum* q = d->qpos;
  // phi - theta = -qpos[hip]; r - r0 = qpos[leg].
  HopperActuation a;
  a.tau_hip = u[0] - vsa.k_hip * (-q[map.qpos_hip]);
  a.f_leg = u[1] - vsa.k_leg * q[map.qpos_leg];
  d->ctrl[map.act_hip] = a.tau_hip;
  d->ctrl[map.act_leg] = a.f_leg;
  return a;
}

void ApplyDragAndPush(const HopperMapping& map, const mjModel* m, mjData* d, double push_x) {
  (void)m;
  const double vx = d->qvel[map.dof_x];
  const double vz = d->qvel[map.dof_z];
  mjtNum* f = d->xfrc_applied + 6 * map.body_torso;
  f[0] = -map.drag_cd * vx * std::abs(vx) + push_x;
  f[1] = 0.0;
  f[2] = -map.drag_cd * vz * std::abs(vz);
  f[3] = f[4] = f[5] = 0.0;
}

double FootNormalForce(const HopperMapping& map, const mjModel* m, const mjData* d) {
  double total = 0.0;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool pair = (c.geom1 == map.geom_foot && c.geom2 == map.geom_floor) ||
                      (c.geom2 == map.geom_foot && c.geom1 == map.geom_floor);
    if (!pair || c.efc_address < 0) continue;
    mjtNum f[6];
    mj_contactForce(m, d, i, f);
    total += f[0];
  }
  return total;
}

}  // namespace ddoc
