// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-drop: drops the MuJoCo hopper from a given flight state with a constant input and writes
//   DIR/trajectory.csv  one row per step: t, mode, the 14 flight coordinates, foot, normal force,
//                       tau_hip, F_leg
//   DIR/events.csv      one row per touchdown/takeoff (ContactPhaseDetector): type, time, foot,
//                       the flight state (before touchdown / after takeoff) and the stance state
//                       (after touchdown / before takeoff)
// Example:
//   ddoc-drop --model models/hopper.xml --state "0,1,0.1,0,0.7,60,2000,0.5,0,0,0,0,0,0"
//             --u "0,0,60,2000" --duration 2 --out out/drop
//   ddoc-drop --model models/hopper.xml --nominal 0.5 --duration 2 --out out/nominal
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/mujoco/hopper_sim.h"
#include "mujoco_warnings.h"
#include "scenario.h"

namespace {

const char* kFlightNames[14] = {"x",  "y",  "theta",  "phi",  "r",  "k_hip",  "k_leg",
                                "xd", "yd", "thetad", "phid", "rd", "k_hipd", "k_legd"};
const char* kStanceNames[10] = {"theta",  "phi",  "r",  "k_hip",  "k_leg",
                                "thetad", "phid", "rd", "k_hipd", "k_legd"};

struct Options {
  std::string model, state, input, out;
  std::vector<std::string> pushes;
  double duration = 2.0;
  std::optional<double> nominal;  // forward speed of the analytic nominal gait, m/s
};

// The start state and the constant input: the nominal gait's, then --state / --u over them.
void StartState(const Options& o, Eigen::Matrix<double, 14, 1>* x0, Eigen::Vector4d* u) {
  if (o.nominal) {
    ddoc::NominalGaitSettings gs;
    gs.forward_speed = *o.nominal;
    const ddoc::NominalGait g = ddoc::FindNominalGait(ddoc::LoadHopperParamsFromMjcf(o.model), gs);
    *x0 = g.x0;
    *u = g.u0;
    std::printf("nominal gait: speed %.3f m/s, apex %.3f m, stance %.3f s, period %.3f s, "
                "I1 %.3g\n", g.forward_speed, g.apex, g.stance_time, g.period, g.periodicity);
  } else if (o.state.empty() || o.input.empty()) {
    throw std::invalid_argument("give --state and --u, or --nominal SPEED");
  }
  if (!o.state.empty()) {
    const std::vector<double> v = ddoc::app::ParseNumberList(o.state, 14, "--state");
    for (int i = 0; i < 14; ++i) (*x0)(i) = v[static_cast<size_t>(i)];
  }
  if (!o.input.empty()) {
    const std::vector<double> v = ddoc::app::ParseNumberList(o.input, 4, "--u");
    for (int i = 0; i < 4; ++i) (*u)(i) = v[static_cast<size_t>(i)];
  }
  const Eigen::Vector4d lo = ddoc::hopper::InputLowerBound(), hi = ddoc::hopper::InputUpperBound();
  if ((u->array() < lo.array()).any() || (u->array() > hi.array()).any()) {
    std::fprintf(stderr, "warning: --u outside the paper's bounds [-4,4]x[-4,4]x[10,150]x"
                         "[1780,2350]\n");
  }
}

// Steps the robot for the duration and writes one trajectory row per step.
int Simulate(ddoc::HopperSim& sim, const Eigen::Vector4d& u, double duration, std::ostream& traj) {
  traj << "t,mode";
  for (const char* n : kFlightNames) traj << "," << n;
  traj << ",foot_x,foot_y,normal_force,tau_hip,f_leg\n";
  auto write_row = [&]() {
    const Eigen::Matrix<double, 14, 1> x = sim.Flight();
    const Eigen::Vector2d f = sim.Foot();
    traj << sim.time() << "," << sim.mode();
    for (int i = 0; i < 14; ++i) traj << "," << x(i);
    traj << "," << f(0) << "," << f(1) << "," << sim.normal_force() << ","
         << sim.actuation().tau_hip << "," << sim.actuation().f_leg << "\n";
  };
  write_row();
  const int steps = static_cast<int>(std::lround(duration / sim.timestep()));
  for (int i = 0; i < steps; ++i) {
    sim.Step(u);
    write_row();
  }
  return steps;
}

void WriteEvents(const std::vector<ddoc::ContactEvent>& events, std::ostream& out) {
  out << "type,time,foot_x,foot_y";
  for (const char* n : kFlightNames) out << ",flight_" << n;
  for (const char* n : kStanceNames) out << ",stance_" << n;
  out << "\n";
  for (const ddoc::ContactEvent& e : events) {
    out << (e.type == ddoc::ContactEvent::Type::kTouchdown ? "touchdown" : "takeoff") << ","
        << e.time << "," << e.foot(0) << "," << e.foot(1);
    for (int i = 0; i < 14; ++i) out << "," << e.flight(i);
    for (int i = 0; i < 10; ++i) out << "," << e.stance(i);
    out << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Drop the MJCF hopper from a state with constant inputs; write trajectory.csv and "
               "events.csv"};
  Options o;
  app.add_option("--model", o.model, "MJCF hopper file (models/hopper.xml, ...)")->required();
  app.add_option("--state", o.state,
                 "14 flight coordinates x,y,theta,phi,r,k_hip,k_leg,xd,yd,thetad,phid,rd,"
                 "k_hipd,k_legd (SI, rad)");
  app.add_option("--u", o.input, "constant input tau0,F0,k0_hip,k0_leg");
  app.add_option("--nominal", o.nominal,
                 "start from the analytic nominal gait with this forward speed (m/s); "
                 "--state/--u override it");
  app.add_option("--duration", o.duration, "simulated time, s")->check(CLI::PositiveNumber);
  app.add_option("--push", o.pushes, "a push TIME,FORCE,DURATION (s, N, s); repeatable");
  app.add_option("--out", o.out, "output directory")->required();
  CLI11_PARSE(app, argc, argv);
  ddoc::app::RouteMujocoWarnings("ddoc-drop");
  try {
    ddoc::HopperSim sim(o.model);
    Eigen::Matrix<double, 14, 1> x0;
    Eigen::Vector4d u;
    StartState(o, &x0, &u);
    for (const std::string& p : o.pushes) sim.AddPush(ddoc::app::ParsePush(p));
    sim.SetFlightState(x0);
    std::error_code ec;
    std::filesystem::create_directories(o.out, ec);
    std::ofstream traj(o.out + "/trajectory.csv");
    std::ofstream events(o.out + "/events.csv");
    if (!traj || !events) throw std::runtime_error("cannot write into --out '" + o.out + "'");
    traj.precision(10);
    events.precision(10);
    const int steps = Simulate(sim, u, o.duration, traj);
    WriteEvents(sim.events(), events);
    std::printf("%d steps of %.4g s, %zu events -> %s/trajectory.csv, %s/events.csv\n", steps,
                sim.timestep(), sim.events().size(), o.out.c_str(), o.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-drop: %s\n", e.what());
    return 2;
  }
  return 0;
}
