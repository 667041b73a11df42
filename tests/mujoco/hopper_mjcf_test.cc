// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// The MJCF variants and the errors for bad MJCF input.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/mujoco/hopper_sim.h"
#include "model_files.h"

namespace ddoc {
namespace {

using testing::ModelCopy;
using testing::ModelPath;

TEST(HopperMjcfTest, VariantsLoadWithDeclaredMassAndDrag) {
  struct Case {
    const char* file;
    double torso_mass;
    double cd;
  };
  for (const Case& c : {Case{"hopper.xml", 10.0, 0.0}, Case{"hopper_m8.xml", 8.0, 0.01},
                        Case{"hopper_m12.xml", 12.0, 0.01}}) {
    HopperSim sim(ModelPath(c.file));
    const mjModel* m = sim.model();
    EXPECT_DOUBLE_EQ(m->body_mass[sim.mapping().body_torso], c.torso_mass) << c.file;
    EXPECT_DOUBLE_EQ(sim.mapping().drag_cd, c.cd) << c.file;
    EXPECT_DOUBLE_EQ(sim.mapping().beta, 20.0) << c.file;
    EXPECT_DOUBLE_EQ(sim.mapping().r0, 0.7) << c.file;
    const HopperParams p = LoadHopperParamsFromMjcf(ModelPath(c.file));
    // M is the flight mass: torso + 1 g leg + 2 g foot.
    EXPECT_NEAR(p.M, c.torso_mass + 0.003, 1e-12) << c.file;
    EXPECT_NEAR(p.J_body, 2.5, 1e-12);
    // J_leg = 0.25 (leg) + the foot's m r0^2 = 0.002 * 0.49 (+ its own 3e-9).
    EXPECT_NEAR(p.J_leg, 0.25 + 0.002 * 0.49, 1e-8);
    EXPECT_NEAR(p.r0, 0.7, 1e-12);
    EXPECT_DOUBLE_EQ(p.c_d, c.cd);
    EXPECT_NEAR(p.g, 9.81, 1e-12);
  }
}

TEST(HopperMjcfTest, ANewVariantIsOneEditedFile) {
  ModelCopy copy;
  std::string text = testing::ReadText(copy.Path("hopper_m12.xml"));
  copy.Write("hopper_m9.xml", text);
  copy.Edit("hopper_m9.xml", "mass=\"12\"", "mass=\"9.5\"");
  copy.Edit("hopper_m9.xml", "name=\"drag_cd\" data=\"0.01\"", "name=\"drag_cd\" data=\"0.03\"");
  const HopperParams p = LoadHopperParamsFromMjcf(copy.Path("hopper_m9.xml"));
  EXPECT_NEAR(p.M, 9.503, 1e-12);
  EXPECT_DOUBLE_EQ(p.c_d, 0.03);
}

// Expects HopperSimError whose message contains every string of `needles`.
void ExpectError(const std::string& path, std::initializer_list<std::string> needles) {
  try {
    HopperSim sim(path);
    FAIL() << "no error for " << path;
  } catch (const HopperSimError& e) {
    const std::string msg = e.what();
    for (const std::string& n : needles) {
      EXPECT_NE(msg.find(n), std::string::npos) << "message lacks '" << n << "': " << msg;
    }
  }
}

// A fresh copy of models/ with one edit (`from` -> `to` in `edited`); loading `loaded` from it
// must throw HopperSimError naming every string of `needles`.
void ExpectErrorAfterEdit(const std::string& edited, const std::string& from, const std::string& to,
                          const std::string& loaded, std::initializer_list<std::string> needles) {
  ModelCopy copy;
  copy.Edit(edited, from, to);
  ExpectError(copy.Path(loaded), needles);
}

TEST(HopperMjcfTest, MalformedXmlNamesFileAndLine) {
  ModelCopy copy;
  copy.Edit("hopper_limbs.xml", "<body name=\"foot\" pos=\"0 0 -0.7\">", "<body name=\"foot\" pos=");
  ExpectError(copy.Path("hopper.xml"), {"hopper_limbs.xml", "malformed XML", "line"});
  ExpectError(copy.Path("does_not_exist.xml"), {"does_not_exist.xml", "not found"});
}

TEST(HopperMjcfTest, MissingNamesAreReported) {
  ExpectErrorAfterEdit("hopper_limbs.xml", "<body name=\"leg\"", "<body name=\"shank\"",
                       "hopper.xml", {"hopper.xml", "no body named 'leg'"});
  // The actuator refers to joint 'hip' too: MuJoCo's compiler names it.
  ExpectErrorAfterEdit("hopper_limbs.xml", "<joint name=\"hip\"", "<joint name=\"hip2\"",
                       "hopper.xml", {"hopper.xml", "hip"});
  ExpectErrorAfterEdit("hopper_limbs.xml", "<joint name=\"pitch\"", "<joint name=\"yaw\"",
                       "hopper.xml", {"hopper.xml", "no joint named 'pitch'"});
  ExpectErrorAfterEdit("hopper_limbs.xml", "<geom name=\"foot\"", "<geom name=\"toe\"",
                       "hopper.xml", {"hopper.xml", "no geom named 'foot'"});
  ExpectErrorAfterEdit("hopper_common.xml", "name=\"floor\"", "name=\"ground\"",
                       "hopper.xml", {"hopper.xml", "no geom named 'floor'"});
  ExpectErrorAfterEdit("hopper_common.xml", "name=\"leg_motor\"", "name=\"knee_motor\"",
                       "hopper.xml", {"hopper.xml", "no actuator named 'leg_motor'"});
  ExpectErrorAfterEdit("hopper_common.xml", "joint=\"hip\" gear=\"-1\"", "joint=\"hip\" gear=\"1\"",
                       "hopper.xml", {"hopper.xml", "hip_motor", "gear -1"});
}

// Issue 20: a typo in a <numeric> name or an attribute is an error naming it, not a default.
TEST(HopperMjcfTest, UnknownNumericsAndAttributesAreNamed) {
  ExpectErrorAfterEdit("hopper_m8.xml", "name=\"drag_cd\"", "name=\"drag_c\"", "hopper_m8.xml",
                       {"hopper_m8.xml", "unknown <numeric name='drag_c'>", "drag_cd"});
  ExpectErrorAfterEdit("hopper.xml", "<numeric name=\"vsa_beta\" data=\"20\"/>",
                       "<numeric name=\"vsa_beta\" data=\"20 30\"/>", "hopper.xml",
                       {"hopper.xml", "vsa_beta", "2 values, expected 1"});
  // MuJoCo's own schema check names an unknown attribute.
  ExpectErrorAfterEdit("hopper_m8.xml", "<inertial pos=", "<inertial poss=", "hopper_m8.xml",
                       {"hopper_m8.xml", "poss"});
}

TEST(HopperMjcfTest, NonPositiveMassOrInertiaNamesFileLineAndBody) {
  ExpectErrorAfterEdit("hopper_m8.xml", "mass=\"8\"", "mass=\"0\"",
                       "hopper_m8.xml", {"hopper_m8.xml", "line", "body 'torso'", "mass = 0"});
  ExpectErrorAfterEdit("hopper_m12.xml", "mass=\"12\"", "mass=\"-12\"",
                       "hopper_m12.xml", {"hopper_m12.xml", "body 'torso'", "mass = -12"});
  ExpectErrorAfterEdit("hopper_limbs.xml", "diaginertia=\"0.25 0.25 0.25\"",
                       "diaginertia=\"0.25 0 0.25\"",
                       "hopper.xml", {"hopper_limbs.xml", "line", "body 'leg'", "diaginertia"});
  ExpectErrorAfterEdit("hopper.xml", "diaginertia=\"2.5 2.5 2.5\"", "diaginertia=\"-2.5 2.5 2.5\"",
                       "hopper.xml", {"hopper.xml", "body 'torso'", "diaginertia"});
}

// The VSA springs are explicit (ctrl held over a step): a timestep at which a spring grows is an
// error naming it. The bound 2 sqrt(I / k) is computed here from the bodies: the leg spring
// moves the 2 g foot against the rest of the robot (reduced mass), so I = m_f m_r / (m_f + m_r).
TEST(HopperMjcfTest, ATimestepAtWhichASpringGrowsIsAnError) {
  const double m_foot = 0.002, m_rest = 8.001;  // hopper_m8.xml: torso 8 kg, leg 1 g
  const double leg_limit = 2.0 * std::sqrt(m_foot * m_rest / (m_foot + m_rest) / 2350.0);
  EXPECT_NEAR(leg_limit, 0.0018448, 1e-7);
  {
    ModelCopy copy;  // just below the bound: loads (and the shipped 0.5 ms does, above)
    copy.Edit("hopper_common.xml", "timestep=\"0.0005\"", "timestep=\"0.00184\"");
    EXPECT_NO_THROW(HopperSim sim(copy.Path("hopper_m8.xml")));
  }
  ExpectErrorAfterEdit("hopper_common.xml", "timestep=\"0.0005\"", "timestep=\"0.002\"",
                       "hopper_m8.xml",
                       {"hopper_m8.xml", "timestep 0.002 s is too long for the leg spring",
                        "effective mass on joint 'leg'", "use a timestep below 0.0018448"});
  // The hip spring binds first with a short, light leg: r0 = 0.1 m, J_leg = 1e-5 kg m^2; the
  // hip's effective inertia is then about J_leg + m_f r0^2 = 3e-5 (bound 0.89 ms).
  ModelCopy copy;
  copy.Edit("hopper_limbs.xml", "diaginertia=\"0.25 0.25 0.25\"", "diaginertia=\"1e-5 1e-5 1e-5\"");
  copy.Edit("hopper_limbs.xml", "<body name=\"foot\" pos=\"0 0 -0.7\">",
            "<body name=\"foot\" pos=\"0 0 -0.1\">");
  copy.Edit("hopper_common.xml", "timestep=\"0.0005\"", "timestep=\"0.001\"");
  ExpectError(copy.Path("hopper_m8.xml"),
              {"timestep 0.001 s is too long for the hip spring", "use a timestep below 0.000"});
}

}  // namespace
}  // namespace ddoc
