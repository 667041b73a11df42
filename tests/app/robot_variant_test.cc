// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// --robot-variant's keys of the unmodelled dynamics (b_leg, b_hip, slope, contact_timeconst): each
// changes what it should in the compiled mjModel and nothing else, equals the shipped MJCF variant
// that carries the same term, and a bad value is named.
#include "robot_variant.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "ddoc/mujoco/hopper_sim.h"

namespace ddoc::app {
namespace {

std::string Model(const std::string& name) { return std::string(DDOC_MODELS_DIR) + "/" + name; }

// The compiled model of ExpandRobotMjcf(path, variant).
MjModelPtr Compile(const std::string& path, const RobotVariant& variant) {
  const std::string text = ExpandRobotMjcf(path, variant);
  const std::string file = "/tmp/ddoc_robot_variant_test_" + std::to_string(::getpid()) + ".xml";
  std::ofstream(file) << text;
  MjModelPtr m = LoadMjcf(file);
  std::remove(file.c_str());
  return m;
}

int Id(const mjModel* m, mjtObj type, const char* name) {
  const int id = mj_name2id(m, type, name);
  EXPECT_GE(id, 0) << name;
  return id;
}

int Dof(const mjModel* m, const char* joint) { return m->jnt_dofadr[Id(m, mjOBJ_JOINT, joint)]; }

// Every number the four keys may touch, equal between a and b (to `tol`).
void ExpectSameTerms(const mjModel* a, const mjModel* b, double tol) {
  ASSERT_EQ(a->nv, b->nv);
  ASSERT_EQ(a->ngeom, b->ngeom);
  for (int i = 0; i < a->nv; ++i) EXPECT_NEAR(a->dof_damping[i], b->dof_damping[i], tol) << i;
  for (int i = 0; i < 3 * a->ngeom; ++i) EXPECT_NEAR(a->geom_pos[i], b->geom_pos[i], tol) << i;
  for (int i = 0; i < 4 * a->ngeom; ++i) EXPECT_NEAR(a->geom_quat[i], b->geom_quat[i], tol) << i;
  for (int i = 0; i < mjNREF * a->ngeom; ++i) {
    EXPECT_NEAR(a->geom_solref[i], b->geom_solref[i], tol) << i;
  }
}

TEST(RobotVariantTest, DampingKeysSetTheJointDamping) {
  RobotVariant v;
  v.b_leg = 3.0;
  const MjModelPtr leg = Compile(Model("hopper_m12.xml"), v);
  v = RobotVariant();
  v.b_hip = 0.7;
  const MjModelPtr hip = Compile(Model("hopper_m12.xml"), v);
  const MjModelPtr plain = LoadMjcf(Model("hopper_m12.xml"));
  for (int i = 0; i < plain->nv; ++i) EXPECT_EQ(plain->dof_damping[i], 0.0);
  EXPECT_EQ(leg->dof_damping[Dof(leg.get(), "leg")], 3.0);
  EXPECT_EQ(hip->dof_damping[Dof(hip.get(), "hip")], 0.7);
  EXPECT_EQ(leg->dof_damping[Dof(leg.get(), "hip")], 0.0);  // one joint each
  EXPECT_EQ(hip->dof_damping[Dof(hip.get(), "leg")], 0.0);
  // The shipped damped variants: the key at the file's value compiles to the file's model.
  v = RobotVariant();
  v.b_leg = 4.0;
  ExpectSameTerms(Compile(Model("hopper.xml"), v).get(),
                  LoadMjcf(Model("hopper_damped_leg.xml")).get(), 0.0);
  v = RobotVariant();
  v.b_hip = 0.5;
  ExpectSameTerms(Compile(Model("hopper.xml"), v).get(),
                  LoadMjcf(Model("hopper_damped_hip.xml")).get(), 0.0);
}

TEST(RobotVariantTest, SlopeTiltsTheFloorAsTheSlopedFile) {
  // models/hopper_slope_down.xml: the 10 kg robot, floor sloped down 2 deg in +x.
  RobotVariant v;
  v.slope = 0.034906585;
  const MjModelPtr variant = Compile(Model("hopper.xml"), v);
  const MjModelPtr file = LoadMjcf(Model("hopper_slope_down.xml"));
  ExpectSameTerms(variant.get(), file.get(), 1e-10);  // the file's pos has 9 digits: 5e-12 m
  // Uphill: the floor's normal leans the other way, (-sin alpha, 0, cos alpha) with alpha = 0.1,
  // and the foot-centre surface passes through the origin.
  v.slope = -0.1;
  const MjModelPtr up = Compile(Model("hopper_m8.xml"), v);
  const int floor = Id(up.get(), mjOBJ_GEOM, "floor");
  mjtNum normal[3];
  const mjtNum z[3] = {0, 0, 1};
  mju_rotVecQuat(normal, z, up->geom_quat + 4 * floor);
  EXPECT_NEAR(normal[0], -std::sin(0.1), 1e-12);
  EXPECT_NEAR(normal[1], 0.0, 1e-12);
  EXPECT_NEAR(normal[2], std::cos(0.1), 1e-12);
  const mjtNum* p = up->geom_pos + 3 * floor;
  const double radius = up->geom_size[3 * Id(up.get(), mjOBJ_GEOM, "foot")];
  EXPECT_NEAR(-(normal[0] * p[0] + normal[2] * p[2]), radius, 1e-12);
}

TEST(RobotVariantTest, ContactTimeconstSetsTheFootFloorSolref) {
  RobotVariant v;
  v.contact_timeconst = 0.004;
  const MjModelPtr soft = Compile(Model("hopper_m12.xml"), v);
  for (const char* g : {"floor", "foot"}) {
    const int id = Id(soft.get(), mjOBJ_GEOM, g);
    EXPECT_EQ(soft->geom_solref[mjNREF * id], 0.004) << g;
    EXPECT_EQ(soft->geom_solref[mjNREF * id + 1], 1.0) << g;  // the damping ratio stays
  }
  // Below 2 x timestep (0.5 ms): named with the bound.
  v.contact_timeconst = 0.0009;
  try {
    ExpandRobotMjcf(Model("hopper_m12.xml"), v);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "--robot-variant: contact_timeconst=0.0009, expected >= 2 x timestep = 0.001 s"),
              std::string::npos)
        << e.what();
  }
}

TEST(RobotVariantTest, RestLengthMovesTheFootAndNothingElse) {
  RobotVariant v;
  v.r0 = 0.72;
  const MjModelPtr longer = Compile(Model("hopper_m8.xml"), v);
  const MjModelPtr plain = LoadMjcf(Model("hopper_m8.xml"));
  const int foot = Id(plain.get(), mjOBJ_BODY, "foot");
  EXPECT_EQ(plain->body_pos[3 * foot + 2], -0.7);
  EXPECT_EQ(longer->body_pos[3 * foot + 2], -0.72);
  // What the robot is, read back the way the runs read it: r0 moved, M, c_d, beta unchanged, and
  // J_leg only by the 2 g foot's m r0^2.
  const HopperParams a = HopperParamsFromModel(plain.get(), "plain");
  const HopperParams b = HopperParamsFromModel(longer.get(), "longer");
  EXPECT_DOUBLE_EQ(b.r0, 0.72);
  EXPECT_EQ(b.M, a.M);
  EXPECT_EQ(b.c_d, a.c_d);
  EXPECT_EQ(b.beta, a.beta);
  const double m_foot = plain->body_mass[foot];
  EXPECT_NEAR(b.J_leg - a.J_leg, m_foot * (0.72 * 0.72 - 0.7 * 0.7), 1e-12);
  ExpectSameTerms(longer.get(), plain.get(), 0.0);
  EXPECT_EQ(v.ToString(), "r0=0.72");
}

TEST(RobotVariantTest, TheFilesOwnValuesGiveThePlainModel) {
  RobotVariant v;
  v.b_leg = 0.0;
  v.b_hip = 0.0;
  v.slope = 0.0;
  v.contact_timeconst = 0.001;
  v.r0 = 0.7;
  for (const char* robot : {"hopper_m8.xml", "hopper_m12.xml"}) {
    SCOPED_TRACE(robot);
    ExpectSameTerms(Compile(Model(robot), v).get(), LoadMjcf(Model(robot)).get(), 0.0);
  }
  EXPECT_EQ(v.ToString(), "b_leg=0,b_hip=0,slope=0,contact_timeconst=0.001,r0=0.7");
}

TEST(RobotVariantTest, BadValuesAreNamed) {
  const struct {
    const char* text;
    const char* message;
  } cases[] = {
      {"b_leg=-1", "--robot-variant: b_leg=-1, expected >= 0"},
      {"b_hip=-0.5", "--robot-variant: b_hip=-0.5, expected >= 0"},
      {"slope=0.3", "--robot-variant: slope=0.3, expected |slope| < 0.3 rad"},
      {"slope=-0.4", "--robot-variant: slope=-0.4, expected |slope| < 0.3 rad"},
      {"contact_timeconst=0", "--robot-variant: contact_timeconst=0, expected > 0 s"},
      {"b_leg=1,b_leg=2", "--robot-variant: b_leg given twice"},
      {"r0=0", "--robot-variant: r0=0, expected > 0"},
      {"r0=-0.7", "--robot-variant: r0=-0.7, expected > 0"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ParseRobotVariant(c.text, "--robot-variant");
      ADD_FAILURE() << "no error";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
    }
  }
  const RobotVariant v =
      ParseRobotVariant("slope=-0.02,b_hip=0.5,contact_timeconst=0.003,b_leg=2", "--robot-variant");
  EXPECT_EQ(v.ToString(), "b_leg=2,b_hip=0.5,slope=-0.02,contact_timeconst=0.003");
}

}  // namespace
}  // namespace ddoc::app
