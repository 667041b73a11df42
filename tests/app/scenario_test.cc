// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "scenario.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "hopper_run.h"
#include "run_log.h"

namespace ddoc::app {
namespace {

namespace fs = std::filesystem;

class ScenarioTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ddoc_scenario_" + std::to_string(::getpid()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "robot.xml") << "<mujoco/>";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& text) {
    const fs::path p = dir_ / "s.xml";
    std::ofstream(p) << text;
    return p.string();
  }

  // The scenario text of a printf format with one %s filled by attrs.
  static std::string Fill(const char* fmt, const char* attrs) {
    char buf[512];
    std::snprintf(buf, sizeof(buf), fmt, attrs);
    return buf;
  }

  // Expects LoadScenario, or ControllerConfigFor on what it read (settings that contradict
  // each other), to throw with a message containing every needle.
  void ExpectError(const std::string& text, std::initializer_list<const char*> needles) {
    const std::string path = Write(text);
    try {
      ControllerConfigFor(LoadScenario(path), HopperParams());
      FAIL() << "no error for:\n" << text;
    } catch (const ScenarioError& e) {
      for (const char* needle : needles) {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
            << "message \"" << e.what() << "\" lacks \"" << needle << "\"";
      }
    }
  }

  fs::path dir_;
};

TEST_F(ScenarioTest, ParsesEveryElementAndResolvesPathsAgainstTheFile) {
  const std::string path = Write(R"(<ddoc_scenario name="x">
      <robot mjcf="robot.xml"/>
      <model M="10" c_d="0" beta="25"/>
      <method name="mrl"/>
      <duration hops="7"/>
      <push time="3" force="25" duration="0.2"/>
      <push time="1" force="-20" duration="0.1"/>
      <gait speed="0.5"/>
    </ddoc_scenario>)");
  const Scenario s = LoadScenario(path);
  EXPECT_EQ(s.name, "x");
  EXPECT_EQ(fs::path(s.robot_mjcf), (dir_ / "robot.xml").lexically_normal());
  EXPECT_EQ(s.method, Method::kMrl);
  EXPECT_EQ(s.hops, 7);
  ASSERT_TRUE(s.model_numbers.mass.has_value());
  EXPECT_DOUBLE_EQ(*s.model_numbers.mass, 10.0);
  EXPECT_DOUBLE_EQ(*s.model_numbers.drag, 0.0);
  EXPECT_DOUBLE_EQ(*s.model_numbers.beta, 25.0);
  EXPECT_FALSE(s.model_numbers.j_leg.has_value());
  ASSERT_EQ(s.pushes.size(), 2u);
  EXPECT_DOUBLE_EQ(s.pushes[0].force, -20.0);  // sorted by time
  EXPECT_DOUBLE_EQ(s.pushes[1].force, 25.0);
  EXPECT_DOUBLE_EQ(s.forward_speed, 0.5);
}

TEST_F(ScenarioTest, UnknownAndRemovedAttributesAreNamed) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><learning %s/></ddoc_scenario>";
  ExpectError(Fill(fmt, "regularization_scaling='per_input'"),
              {"<learning>", "unknown attribute regularization_scaling", "removed"});
  ExpectError(Fill(fmt, "flight_pitch_feedback='0.5'"),
              {"unknown attribute flight_pitch_feedback", "<experiment"});
  ExpectError(Fill(fmt, "gama='0.5'"), {"<learning>", "unknown attribute gama", "gamma"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml' mass='3'/></ddoc_scenario>",
              {"<robot>", "unknown attribute mass", "expected mjcf"});
}

TEST_F(ScenarioTest, LearningCyclicValueAndAlphaInitial) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><learning %s/></ddoc_scenario>";
  const Scenario s = LoadScenario(Write(Fill(fmt, "cyclic_value='0.9' alpha_initial='0.3'")));
  ASSERT_TRUE(s.learning.cyclic_value.has_value());
  EXPECT_DOUBLE_EQ(*s.learning.cyclic_value, 0.9);
  ASSERT_TRUE(s.learning.alpha_initial.has_value());
  EXPECT_DOUBLE_EQ(*s.learning.alpha_initial, 0.3);
  ExpectError(Fill(fmt, "cyclic_value='1.5'"), {"cyclic_value", "[0, 1]"});
  ExpectError(Fill(fmt, "alpha_initial='0'"), {"alpha_initial", "(0, 1]"});
  ExpectError(Fill(fmt, "cyclic_value='abc'"), {"cyclic_value"});
}

TEST_F(ScenarioTest, GaitStiffness) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><gait %s/></ddoc_scenario>";
  Scenario s = LoadScenario(Write(Fill(fmt, "speed='0.4' k0_hip='30' k0_leg='2100'")));
  EXPECT_DOUBLE_EQ(s.forward_speed, 0.4);
  ASSERT_TRUE(s.gait_k0_hip.has_value());
  EXPECT_DOUBLE_EQ(*s.gait_k0_hip, 30.0);
  ASSERT_TRUE(s.gait_k0_leg.has_value());
  EXPECT_DOUBLE_EQ(*s.gait_k0_leg, 2100.0);
  s = LoadScenario(Write(Fill(fmt, "speed='0.4'")));
  EXPECT_FALSE(s.gait_k0_hip.has_value());
  EXPECT_FALSE(s.gait_k0_leg.has_value());
  ExpectError(Fill(fmt, "k0_hip='5'"), {"k0_hip = 5", "[10, 150]"});
  ExpectError(Fill(fmt, "k0_leg='2400'"), {"k0_leg = 2400", "[1780, 2350]"});
  ExpectError(Fill(fmt, "k0_hip='soft'"), {"k0_hip"});
}

TEST_F(ScenarioTest, LearningTerminalAndInitialHops) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><learning %s/></ddoc_scenario>";
  Scenario s = LoadScenario(Write(Fill(fmt, "terminal='event' initial_hops='2' reference='gait'")));
  ASSERT_TRUE(s.learning.anchor_reference.has_value());
  EXPECT_TRUE(*s.learning.anchor_reference);
  ASSERT_TRUE(s.learning.terminal_event.has_value());
  EXPECT_TRUE(*s.learning.terminal_event);
  ASSERT_TRUE(s.learning.initial_hops.has_value());
  EXPECT_EQ(*s.learning.initial_hops, 2);
  s = LoadScenario(Write(Fill(fmt, "terminal='time'")));
  ASSERT_TRUE(s.learning.terminal_event.has_value());
  EXPECT_FALSE(*s.learning.terminal_event);
  EXPECT_FALSE(s.learning.initial_hops.has_value());
  EXPECT_FALSE(s.learning.anchor_reference.has_value());
  s = LoadScenario(Write(Fill(fmt, "reference='own'")));
  ASSERT_TRUE(s.learning.anchor_reference.has_value());
  EXPECT_FALSE(*s.learning.anchor_reference);
  EXPECT_FALSE(s.learning.anchor_weight.has_value());
  s = LoadScenario(Write(Fill(fmt, "reference='gait' anchor_weight='0.9'")));
  ASSERT_TRUE(s.learning.anchor_weight.has_value());
  EXPECT_EQ(*s.learning.anchor_weight, 0.9);
  ExpectError(Fill(fmt, "anchor_weight='1.5'"), {"<learning>", "anchor_weight", "1.5"});
  ExpectError(Fill(fmt, "anchor_weight='-0.5'"), {"<learning>", "anchor_weight", "-0.5"});
  EXPECT_FALSE(s.learning.reference_filter.has_value());
  s = LoadScenario(Write(Fill(fmt, "anchor_weight='0.5' reference_filter='0.1'")));
  ASSERT_TRUE(s.learning.reference_filter.has_value());
  EXPECT_EQ(*s.learning.reference_filter, 0.1);
  ExpectError(Fill(fmt, "reference_filter='0'"), {"<learning>", "reference_filter", "0"});
  ExpectError(Fill(fmt, "reference_filter='1.5'"), {"<learning>", "reference_filter", "1.5"});
  EXPECT_FALSE(s.learning.overspeed_latch.has_value());
  s = LoadScenario(
      Write(Fill(fmt, "anchor_weight='0' reference_filter='0.05' overspeed_latch='0.05'")));
  ASSERT_TRUE(s.learning.overspeed_latch.has_value());
  EXPECT_EQ(*s.learning.overspeed_latch, 0.05);
  ExpectError(Fill(fmt, "overspeed_latch='-0.1'"), {"<learning>", "overspeed_latch", "-0.1"});
  ExpectError(Fill(fmt, "reference='nominal'"),
              {"<learning>", "reference=\"nominal\"", "own or gait"});
  ExpectError(Fill(fmt, "terminal='takeoff'"),
              {"<learning>", "terminal=\"takeoff\"", "time or event"});
  ExpectError(Fill(fmt, "initial_hops='0'"), {"initial_hops", ">= 1"});
  ExpectError(Fill(fmt, "initial_hops='1.5'"), {"initial_hops", "integer"});
  // preset="paper": Algorithm 1 as printed (ControllerConfigFor); "default" or absent: not.
  EXPECT_FALSE(s.learning.paper);
  s = LoadScenario(Write(Fill(fmt, "preset='paper'")));
  EXPECT_TRUE(s.learning.paper);
  s = LoadScenario(Write(Fill(fmt, "preset='default'")));
  EXPECT_FALSE(s.learning.paper);
  ExpectError(Fill(fmt, "preset='papr'"), {"<learning>", "preset=\"papr\"", "default or paper"});
}

TEST_F(ScenarioTest, LearningRemeasureNoiseMarginAndHopsPerTrial) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><learning %s/></ddoc_scenario>";
  Scenario s = LoadScenario(Write(Fill(fmt, "remeasure='on' noise_margin='1.5'")));
  ASSERT_TRUE(s.learning.remeasure.has_value());
  EXPECT_TRUE(*s.learning.remeasure);
  ASSERT_TRUE(s.learning.noise_margin.has_value());
  EXPECT_DOUBLE_EQ(*s.learning.noise_margin, 1.5);
  LearnerSettings l = ControllerConfigFor(s, HopperParams()).driver.learner;
  EXPECT_TRUE(l.remeasure_nominal);
  EXPECT_DOUBLE_EQ(l.noise_margin, 1.5);
  s = LoadScenario(Write(Fill(fmt, "remeasure='off'")));
  EXPECT_FALSE(*s.learning.remeasure);
  EXPECT_FALSE(s.learning.noise_margin.has_value());
  l = ControllerConfigFor(LoadScenario(Write(Fill(fmt, ""))), HopperParams()).driver.learner;
  EXPECT_FALSE(l.remeasure_nominal);  // the hopper's default
  EXPECT_EQ(l.noise_margin, 0.0);
  ExpectError(Fill(fmt, "remeasure='yes'"), {"<learning>", "remeasure=\"yes\"", "off or on"});
  // blend_feedback: on in the hopper's default, off in the paper preset and the model solve.
  plugin::ControllerConfig c =
      ControllerConfigFor(LoadScenario(Write(Fill(fmt, ""))), HopperParams());
  EXPECT_TRUE(c.driver.learner.blend_feedback);
  EXPECT_FALSE(c.model_learner.blend_feedback);
  EXPECT_FALSE(ControllerConfigFor(LoadScenario(Write(Fill(fmt, "preset='paper'"))), HopperParams())
                   .driver.learner.blend_feedback);
  s = LoadScenario(Write(Fill(fmt, "blend_feedback='off'")));
  EXPECT_FALSE(ControllerConfigFor(s, HopperParams()).driver.learner.blend_feedback);
  ExpectError(Fill(fmt, "blend_feedback='1'"), {"<learning>", "blend_feedback=\"1\"", "off or on"});
  // blend_feedforward and min_predicted_decrease: off and 0 unless set.
  EXPECT_FALSE(c.driver.learner.blend_feedforward);
  EXPECT_EQ(c.driver.learner.min_predicted_decrease, 0.0);
  l = ControllerConfigFor(
          LoadScenario(Write(Fill(fmt, "blend_feedforward='on' min_predicted_decrease='0.02'"))),
          HopperParams())
          .driver.learner;
  EXPECT_TRUE(l.blend_feedforward);
  EXPECT_EQ(l.min_predicted_decrease, 0.02);
  ExpectError(Fill(fmt, "blend_feedforward='yes'"),
              {"<learning>", "blend_feedforward=\"yes\"", "off or on"});
  ExpectError(Fill(fmt, "min_predicted_decrease='-1'"),
              {"<learning>", "min_predicted_decrease = -1"});
  ExpectError(Fill(fmt, "noise_margin='-1'"), {"noise_margin"});
  s = LoadScenario(Write(Fill(fmt, "hops_per_trial='3'")));
  EXPECT_EQ(ControllerConfigFor(s, HopperParams()).driver.runs_per_trial, 3);
  EXPECT_EQ(c.driver.runs_per_trial, 1);  // the default configuration, c above
  ExpectError(Fill(fmt, "hops_per_trial='0'"), {"hops_per_trial", ">= 1"});
  // start_correction (off in the hopper's default, c above) and restart_alpha (1e-3 there).
  EXPECT_FALSE(c.driver.learner.start_correction);
  EXPECT_DOUBLE_EQ(c.driver.learner.restart_alpha, 1e-3);
  c = ControllerConfigFor(
      LoadScenario(Write(Fill(fmt, "start_correction='on' restart_alpha='0.25'"))), HopperParams());
  EXPECT_TRUE(c.driver.learner.start_correction);
  EXPECT_DOUBLE_EQ(c.driver.learner.restart_alpha, 0.25);
  ExpectError(Fill(fmt, "start_correction='yes'"), {"start_correction=\"yes\"", "off or on"});
  ExpectError(Fill(fmt, "restart_alpha='0'"), {"restart_alpha"});
  ExpectError(Fill(fmt, "restart_alpha='1.5'"), {"restart_alpha"});
  // The harm guard's interleaved comparison (off by default) and the anchor weight.
  EXPECT_FALSE(c.driver.guard.interleave);
  EXPECT_FALSE(c.driver.guard.log_cost);
  EXPECT_FALSE(c.driver.guard.only_when_worse);
  EXPECT_DOUBLE_EQ(c.anchor_weight, 1.0);
  EXPECT_DOUBLE_EQ(c.reference_filter, 1.0);
  EXPECT_FALSE(c.driver.learner.reference_shift);
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "reference_filter='0.2'"))),
                          HopperParams());
  EXPECT_DOUBLE_EQ(c.reference_filter, 0.2);
  EXPECT_DOUBLE_EQ(c.overspeed_latch, 0.0);
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "anchor_weight='0' reference_filter='0.2' "
                                                       "overspeed_latch='0.1'"))),
                          HopperParams());
  EXPECT_DOUBLE_EQ(c.overspeed_latch, 0.1);
  c = ControllerConfigFor(
      LoadScenario(Write(Fill(fmt, "verify_hops='3' verify_interleave='on' verify_log='on' "
                                   "verify_when='worse' anchor_weight='0.8'"))),
      HopperParams());
  EXPECT_TRUE(c.driver.guard.interleave);
  EXPECT_TRUE(c.driver.guard.log_cost);
  EXPECT_TRUE(c.driver.guard.only_when_worse);
  EXPECT_EQ(c.driver.guard.verify_trials, 3);
  EXPECT_DOUBLE_EQ(c.anchor_weight, 0.8);
  ExpectError(Fill(fmt, "verify_interleave='2'"), {"verify_interleave=\"2\"", "off or on"});
  ExpectError(Fill(fmt, "verify_when='sometimes'"),
              {"verify_when=\"sometimes\"", "always, worse or never"});
  // The default's median watch (HopperTrialSettings): accepted laws kept on their own trial, the
  // last 8 judged costs watched against 1.5 x the law to go back to, u^0 included, and only on a
  // robot no heavier than 1.05 x the given model's M.
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, ""))), HopperParams());
  EXPECT_EQ(c.driver.guard.verify_trials, 3);
  EXPECT_EQ(c.driver.guard.watch_trials, 8);
  EXPECT_FALSE(c.driver.guard.verify_accepted);
  EXPECT_DOUBLE_EQ(c.driver.guard.watch_ratio, 1.5);
  EXPECT_TRUE(c.driver.guard.watch_initial);
  EXPECT_DOUBLE_EQ(c.watch_max_mass, 1.05);
  // verify_hops='0' turns the guard off, its watch with it; the paper preset has none.
  for (const char* off : {"verify_hops='0'", "preset='paper'"}) {
    c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, off))), HopperParams());
    EXPECT_EQ(c.driver.guard.verify_trials, 0) << off;
    EXPECT_EQ(c.driver.guard.watch_trials, 0) << off;
    EXPECT_TRUE(c.driver.guard.verify_accepted) << off;
    EXPECT_DOUBLE_EQ(c.driver.guard.watch_ratio, 0.0) << off;
  }
  c = ControllerConfigFor(
      LoadScenario(Write(Fill(fmt, "watch_hops='6' verify_when='always' watch_ratio='2' "
                                   "watch_u0='off'"))),
      HopperParams());
  EXPECT_TRUE(c.driver.guard.verify_accepted);
  EXPECT_FALSE(c.driver.guard.only_when_worse);
  EXPECT_DOUBLE_EQ(c.driver.guard.watch_ratio, 2.0);
  EXPECT_FALSE(c.driver.guard.watch_initial);
  EXPECT_EQ(c.driver.guard.watch_trials, 6);
  ExpectError(Fill(fmt, "watch_u0='no'"), {"watch_u0=\"no\"", "off or on"});
  ExpectError(Fill(fmt, "watch_ratio='-1'"), {"watch_ratio"});
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "watch_max_mass='1.2'"))), HopperParams());
  EXPECT_DOUBLE_EQ(c.watch_max_mass, 1.2);
  // A mass limit of the watch in a scenario without a watch names both.
  ExpectError(Fill(fmt, "verify_hops='0' watch_max_mass='1.2'"), {"watch_max_mass", "watch_hops"});
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "watch_max_mass='0'"))), HopperParams());
  EXPECT_DOUBLE_EQ(c.watch_max_mass, 0.0);  // 0: the watch on every robot
  ExpectError(Fill(fmt, "watch_max_mass='-1'"), {"watch_max_mass", "-1"});
}

TEST_F(ScenarioTest, PitchFeedbackExperiment) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><experiment %s/></ddoc_scenario>";
  Scenario s = LoadScenario(Write(Fill(fmt, "flight_pitch_feedback='0.5' from_hop='12'")));
  ASSERT_TRUE(s.experiment.flight_pitch_feedback.has_value());
  EXPECT_EQ(*s.experiment.flight_pitch_feedback, 0.5);
  ASSERT_TRUE(s.experiment.from_hop.has_value());
  EXPECT_EQ(*s.experiment.from_hop, 12);
  s = LoadScenario(Write(Fill(fmt, "")));
  EXPECT_FALSE(s.experiment.flight_pitch_feedback.has_value());
  EXPECT_FALSE(s.experiment.from_hop.has_value());
  ExpectError(Fill(fmt, "flight_pitch_feedback='1.5'"), {"flight_pitch_feedback", "[0, 1]"});
  ExpectError(Fill(fmt, "flight_pitch_feedback='-0.1'"), {"flight_pitch_feedback", "[0, 1]"});
  ExpectError(Fill(fmt, "from_hop='2.5'"), {"from_hop", "integer"});
}

TEST_F(ScenarioTest, ContactSubstepEvents) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><contact %s/></ddoc_scenario>";
  EXPECT_FALSE(ControllerConfigFor(LoadScenario(Write(Fill(fmt, ""))), HopperParams())
                   .contact.substep_events);  // the default: off
  Scenario s = LoadScenario(Write(Fill(fmt, "substep_events='on'")));
  EXPECT_TRUE(ControllerConfigFor(s, HopperParams()).contact.substep_events);
  s = LoadScenario(Write(Fill(fmt, "substep_events='off'")));
  EXPECT_FALSE(ControllerConfigFor(s, HopperParams()).contact.substep_events);
  ExpectError(Fill(fmt, "substep_events='1'"), {"<contact>", "substep_events=\"1\"", "off or on"});
  ExpectError(Fill(fmt, "takeoff_force='1'"),
              {"<contact>", "unknown attribute takeoff_force", "expected substep_events"});
}

TEST_F(ScenarioTest, Identification) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/><identification %s/></ddoc_scenario>";
  plugin::ControllerConfig c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, ""))), HopperParams());
  EXPECT_FALSE(c.identification.mass);  // the default: off
  EXPECT_FALSE(c.identification.terms);
  EXPECT_EQ(c.identification.settle_hops, 2);
  EXPECT_EQ(c.identification.settle_cost, 2.0);
  EXPECT_EQ(c.identification.settle_hops_max, 30);
  EXPECT_EQ(c.identification.resolve_latency, 0.1);
  EXPECT_TRUE(c.identification.model_law);
  EXPECT_EQ(c.identification.min_predicted_decrease, 0.03);
  c = ControllerConfigFor(
      LoadScenario(Write(Fill(fmt, "mass='on' model_law='off' min_predicted_decrease='0.05'"))),
      HopperParams());
  EXPECT_FALSE(c.identification.model_law);
  EXPECT_EQ(c.identification.min_predicted_decrease, 0.05);
  ExpectError(Fill(fmt, "model_law='1'"), {"<identification>", "model_law=\"1\"", "off or on"});
  ExpectError(Fill(fmt, "min_predicted_decrease='-2'"),
              {"<identification>", "min_predicted_decrease = -2"});
  c = ControllerConfigFor(
      LoadScenario(Write(Fill(fmt, "mass='on' settle_hops='0' settle_cost='2.5' "
                                   "settle_hops_max='7' resolve_latency='0.5'"))),
      HopperParams());
  EXPECT_TRUE(c.identification.mass);
  EXPECT_FALSE(c.identification.terms);
  EXPECT_EQ(c.identification.settle_hops, 0);
  EXPECT_EQ(c.identification.settle_cost, 2.5);
  EXPECT_EQ(c.identification.settle_hops_max, 7);
  EXPECT_EQ(c.identification.resolve_latency, 0.5);
  ExpectError(Fill(fmt, "settle_cost='-1'"), {"<identification>", "settle_cost = -1"});
  ExpectError(Fill(fmt, "resolve_latency='-1'"), {"<identification>", "resolve_latency = -1"});
  ExpectError(Fill(fmt, "mass='yes'"), {"<identification>", "mass=\"yes\"", "off or on"});
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "terms='on'"))), HopperParams());
  EXPECT_TRUE(c.identification.terms);
  EXPECT_FALSE(c.identification.mass);
  ExpectError(Fill(fmt, "terms='1'"), {"<identification>", "terms=\"1\"", "off or on"});
  EXPECT_EQ(c.identification.terms_estimator.acted, TermsIdentification::Settings::Acted());
  c = ControllerConfigFor(LoadScenario(Write(Fill(fmt, "terms='on' terms_acted='b_leg,slope'"))),
                          HopperParams());
  EXPECT_EQ(c.identification.terms_estimator.acted, ParseActedTerms("b_leg,slope"));
  ExpectError(Fill(fmt, "terms_acted='b_leg,b_hips'"),
              {"<identification>", "terms_acted", "unknown term \"b_hips\""});
  ExpectError(Fill(fmt, "settle_hops='-1'"), {"<identification>", "settle_hops = -1", ">= 0"});
  ExpectError(Fill(fmt, "drag='on'"),
              {"<identification>", "unknown attribute drag",
               "expected mass, terms, terms_acted, settle_hops, settle_cost, settle_hops_max, "
               "resolve_latency, model_law, min_predicted_decrease"});
}

TEST_F(ScenarioTest, BadInputNamesTheProblem) {
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/>", {"s.xml", "malformed XML"});
  ExpectError("<scenario/>", {"<ddoc_scenario>"});
  ExpectError("<ddoc_scenario><model M='10'/></ddoc_scenario>", {"no robot MJCF"});
  ExpectError("<ddoc_scenario><robot mjcf='nope.xml'/></ddoc_scenario>", {"nope.xml", "does not exist"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><method name='ppo'/></ddoc_scenario>",
              {"ppo", "alg1"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><model M='ten'/></ddoc_scenario>",
              {":1", "<model>", "M=\"ten\""});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><model M='-1'/></ddoc_scenario>",
              {"s.xml:1", "<model>", "M = -1", "out of range", "> 0"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><push time='1' force='2'/></ddoc_scenario>",
              {"<push>", "duration"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><push time='1' force='2' duration='0'/></ddoc_scenario>",
              {"s.xml:1", "<push>", "duration = 0", "out of range", "> 0"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><duration hops='0'/></ddoc_scenario>",
              {"hops or of seconds"});
  ExpectError("<ddoc_scenario><robot mjcf='robot.xml'/><wind/></ddoc_scenario>", {"<wind>"});
  EXPECT_THROW(LoadScenario((dir_ / "missing.xml").string()), ScenarioError);
}

// Issue 20: a typo in an attribute, a value out of its range, a number with trailing characters,
// a non-finite or oversized number, a child element, text, or an element given twice is an error
// naming the file, the line, the element and the attribute; nothing is silently ignored.
TEST_F(ScenarioTest, StrictFilesNameFileLineElementAndAttribute) {
  const char* fmt = "<ddoc_scenario>\n<robot mjcf='robot.xml'/>\n<learning %s/>\n</ddoc_scenario>";
  ExpectError(Fill(fmt, "cyclic='0.99'"),
              {"s.xml:3", "<learning>", "unknown attribute cyclic", "cyclic_value"});
  ExpectError(Fill(fmt, "gamma='1'"), {"s.xml:3", "<learning>", "gamma = 1", "in (0, 1)"});
  ExpectError(Fill(fmt, "c='0'"), {"s.xml:3", "<learning>", "c = 0", "> 0"});
  ExpectError(Fill(fmt, "regularization='-1'"), {"s.xml:3", "regularization = -1", ">= 0"});
  ExpectError(Fill(fmt, "delta_i='1e12'"), {"s.xml:3", "delta_i = 1e12", "out of range"});
  ExpectError(Fill(fmt, "gamma='0.5abc'"), {"s.xml:3", "gamma=\"0.5abc\"", "not a finite number"});
  ExpectError(Fill(fmt, "gamma='nan'"), {"s.xml:3", "gamma=\"nan\"", "not a finite number"});
  ExpectError(Fill(fmt, "epsilon='inf'"), {"epsilon=\"inf\"", "not a finite number"});
  ExpectError(Fill(fmt, "epsilon='1e999'"), {"epsilon=\"1e999\"", "not a finite number"});
  ExpectError(Fill(fmt, "epsilon='0x10'"), {"epsilon=\"0x10\"", "not a finite number"});
  ExpectError(Fill(fmt, "epsilon=''"), {"epsilon=\"\"", "not a finite number"});
  const char* body = "<ddoc_scenario>\n<robot mjcf='robot.xml'/>\n%s\n</ddoc_scenario>";
  ExpectError(Fill(body, "<duration hops='1e12'/>"), {"s.xml:3", "<duration>", "hops = 1e12"});
  ExpectError(Fill(body, "<duration hops='2.5'/>"), {"s.xml:3", "hops = 2.5", "not an integer"});
  ExpectError(Fill(body, "<duration seconds='-1'/>"), {"s.xml:3", "seconds = -1", ">= 0"});
  ExpectError(Fill(body, "<gait speed='0.5' k0_hip='151'/>"),
              {"s.xml:3", "<gait>", "k0_hip = 151", "[10, 150]"});
  ExpectError(Fill(body, "<model beta='0'/>"), {"s.xml:3", "<model>", "beta = 0", "> 0"});
  ExpectError(Fill(body, "<model c_d='-0.1'/>"), {"s.xml:3", "c_d = -0.1", ">= 0"});
  ExpectError(Fill(body, "<push time='-1' force='1' duration='1'/>"),
              {"s.xml:3", "<push>", "time = -1", ">= 0"});
  ExpectError(Fill(body, "<push time='1' force='huge' duration='1'/>"),
              {"s.xml:3", "<push>", "force=\"huge\""});
  ExpectError(Fill(body, "<experiment from_hop='0'/>"), {"s.xml:3", "from_hop = 0", ">= 1"});
  ExpectError(Fill(body, "<learning>\n<gamma>0.5</gamma>\n</learning>"),
              {"s.xml:4", "<learning> has a child element <gamma>", "attributes only"});
  ExpectError(Fill(body, "<learning>gamma=0.5</learning>"),
              {"s.xml:3", "<learning> has text \"gamma=0.5\""});
  ExpectError(Fill(body, "stray text"), {"s.xml:", "<ddoc_scenario> has text \"", "stray text"});
  ExpectError(Fill(body, "<learning gamma='0.5'/>\n<learning c='1'/>"),
              {"s.xml:4", "<learning> is given twice (first at line 3)"});
  ExpectError(Fill(body, "<robot mjcf='robot.xml'/>"), {"s.xml:3", "<robot> is given twice"});
  ExpectError(Fill(body, "<ddoc_scenario/>"), {"s.xml:3", "unknown element <ddoc_scenario>"});
  ExpectError("<ddoc_scenario nmae='x'><robot mjcf='robot.xml'/></ddoc_scenario>",
              {"s.xml:1", "<ddoc_scenario>", "unknown attribute nmae", "name"});
  // Pushes repeat; comments and whitespace are fine.
  const Scenario s = LoadScenario(Write(Fill(
      body, "<!-- two pushes -->\n<push time='1' force='2' duration='0.1'/>\n"
            "<push time='2' force='-2' duration='0.1'/>\n<duration hops='3'/>")));
  EXPECT_EQ(s.pushes.size(), 2u);
  EXPECT_EQ(s.hops, 3);
}

TEST(ParseNumberListTest, ExactlyNFiniteNumbers) {
  const std::vector<double> v = ParseNumberList("1, -2.5,3e2 ", 3, "--u");
  ASSERT_EQ(v.size(), 3u);
  EXPECT_DOUBLE_EQ(v[1], -2.5);
  EXPECT_DOUBLE_EQ(v[2], 300.0);
  auto expect_error = [](const std::string& text, const std::string& needle) {
    try {
      ParseNumberList(text, 3, "--u");
      ADD_FAILURE() << "no error for " << text;
    } catch (const ScenarioError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("1,2", "--u: got 2 values, expected 3");
  expect_error("1,2,3,4", "got 4 values");
  expect_error("1,nan,3", "--u: 'nan' is not a finite number");
  expect_error("1,inf,3", "'inf'");
  expect_error("1,2x,3", "'2x'");
  expect_error("1,,3", "'' is not a finite number");
  expect_error("1,2,1e400", "'1e400'");
}

TEST(ParsePushTest, AcceptsTripletsOnly) {
  const Push p = ParsePush("2.5,-20,0.2");
  EXPECT_DOUBLE_EQ(p.time, 2.5);
  EXPECT_DOUBLE_EQ(p.force, -20.0);
  EXPECT_DOUBLE_EQ(p.duration, 0.2);
  EXPECT_THROW(ParsePush("2.5,-20"), ScenarioError);
  EXPECT_THROW(ParsePush("2.5;-20;0.2"), ScenarioError);
  EXPECT_THROW(ParsePush("1,2,0"), ScenarioError);
  EXPECT_THROW(ParsePush("1,2,3,4"), ScenarioError);
  EXPECT_THROW(ParsePush("nan,1,1"), ScenarioError);
  EXPECT_THROW(ParsePush("1,inf,1"), ScenarioError);
  EXPECT_THROW(ParsePush("1,1,1e999"), ScenarioError);
  EXPECT_THROW(ParsePush("1,1,1junk"), ScenarioError);
}

TEST_F(ScenarioTest, PushByHopPhase) {
  const char* fmt = "<ddoc_scenario><robot mjcf='robot.xml'/>%s</ddoc_scenario>";
  Scenario s = LoadScenario(Write(Fill(
      fmt, "<push hop='30' phase='0.5' force='25' duration='0.2'/>"
           "<push hop='15' phase='0.375' force='-20' duration='0.1'/>"
           "<push time='2' force='5' duration='0.1'/>")));
  ASSERT_EQ(s.pushes.size(), 1u);
  EXPECT_DOUBLE_EQ(s.pushes[0].time, 2.0);
  ASSERT_EQ(s.hop_pushes.size(), 2u);
  EXPECT_EQ(s.hop_pushes[0].hop, 15);  // sorted by hop
  EXPECT_DOUBLE_EQ(s.hop_pushes[0].phase, 0.375);
  EXPECT_DOUBLE_EQ(s.hop_pushes[0].force, -20.0);
  EXPECT_DOUBLE_EQ(s.hop_pushes[0].duration, 0.1);
  EXPECT_EQ(s.hop_pushes[1].hop, 30);
  ExpectError(Fill(fmt, "<push time='1' hop='3' phase='0' force='2' duration='0.1'/>"),
              {"either time or hop and phase"});
  ExpectError(Fill(fmt, "<push force='2' duration='0.1'/>"), {"either time or hop and phase"});
  ExpectError(Fill(fmt, "<push hop='3' force='2' duration='0.1'/>"), {"<push>", "phase"});
  ExpectError(Fill(fmt, "<push phase='0.5' force='2' duration='0.1'/>"), {"<push>", "hop"});
  ExpectError(Fill(fmt, "<push hop='0' phase='0' force='2' duration='0.1'/>"),
              {"<push> hop = 0 is out of range", "an integer >= 1"});
  ExpectError(Fill(fmt, "<push hop='2.5' phase='0' force='2' duration='0.1'/>"),
              {"<push> hop = 2.5 is not an integer"});
  ExpectError(Fill(fmt, "<push hop='3' phase='1' force='2' duration='0.1'/>"),
              {"<push> phase = 1 is out of range", "[0, 1)"});
  ExpectError(Fill(fmt, "<push hop='3' phase='-0.1' force='2' duration='0.1'/>"),
              {"<push> phase = -0.1 is out of range", "[0, 1)"});
  ExpectError(Fill(fmt, "<push hop='3' phase='0.5' force='2' duration='0'/>"),
              {"<push> duration = 0 is out of range", "> 0"});
}

TEST(ParsePushTest, ByHopPhase) {
  const HopPush p = ParseHopPush("30@0.375,-20,0.2");
  EXPECT_EQ(p.hop, 30);
  EXPECT_DOUBLE_EQ(p.phase, 0.375);
  EXPECT_DOUBLE_EQ(p.force, -20.0);
  EXPECT_DOUBLE_EQ(p.duration, 0.2);
  for (const char* bad : {"30,0.375,-20,0.2", "30@0.375,-20", "0@0.5,1,0.1", "3.5@0.5,1,0.1",
                          "3@1,1,0.1", "3@0.5,1,0", "3@0.5,1,0.1,4"}) {
    EXPECT_THROW(ParseHopPush(bad), ScenarioError) << bad;
  }
}

TEST(RunLogTest, WritesHeadersRowsAndAtomicSummary) {
  const fs::path dir =
      fs::temp_directory_path() / ("ddoc_runlog_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  {
    RunLog log(dir.string(), "alg1");
    plugin::HopReport h;
    h.hop = 3;
    h.cost = 1.5;
    h.accepted = true;
    log.WriteHop(h);
    // Written before the log is closed: a run that dies keeps its rows.
    std::ifstream in(dir / "hops.csv");
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    EXPECT_EQ(header.substr(0, 18), "hop,t_start,t_end,");
    EXPECT_EQ(row.substr(0, 2), "3,");
    EXPECT_NE(row.find(",1,"), std::string::npos);
    Summary s;
    s.scenario = "a\"b";
    s.final_cost = std::nan("");
    log.WriteSummary(s);
    std::ifstream js(dir / "summary.json");
    const std::string text((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("\"a\\\"b\""), std::string::npos);
    EXPECT_NE(text.find("\"final_cost\": null"), std::string::npos);
  }
  fs::remove_all(dir);
  EXPECT_THROW(RunLog("/proc/ddoc_cannot_write_here", "alg1"), std::runtime_error);
}

// trajectory.csv's rows are printf's "%.6f,%d,%d" and ",%.7g" x 18 and ",%.4g": the same text,
// byte for byte, for ordinary, huge, tiny, negative-zero and non-finite values.
TEST(RunLogTest, TrajectoryRowsArePrintfsText) {
  const fs::path dir =
      fs::temp_directory_path() / ("ddoc_runlog_rows_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const double values[] = {0.0, -0.0, 1.0 / 3.0, -2.5e-7, 123456789.0, 1e300, -1e-300, 5e-324,
                           std::nan(""), -std::numeric_limits<double>::infinity(), 0.1, 42.0};
  std::string expected;
  {
    RunLog log(dir.string(), "alg1");
    for (int r = 0; r < 12; ++r) {
      SampleRecord s;
      s.t = values[r] * 7.0;
      s.hop = r - 3;
      s.phase = r % 2;
      for (int i = 0; i < 14; ++i) s.q[i] = values[(r + i) % 12] * (i + 1);
      for (int i = 0; i < 4; ++i) s.u[i] = values[(r + 2 * i) % 12];
      s.push = values[(r + 5) % 12];
      log.WriteSample(s);
      char buf[400];  // "%.6f" of 7e300 has 308 digits
      std::snprintf(buf, sizeof(buf), "%.6f,%d,%d", s.t, s.hop, s.phase);
      expected += buf;
      for (double v : s.q) {
        std::snprintf(buf, sizeof(buf), ",%.7g", v);
        expected += buf;
      }
      for (double v : s.u) {
        std::snprintf(buf, sizeof(buf), ",%.7g", v);
        expected += buf;
      }
      std::snprintf(buf, sizeof(buf), ",%.4g\n", s.push);
      expected += buf;
    }
  }
  std::ifstream in(dir / "trajectory.csv");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string rows = text.substr(text.find('\n') + 1);  // after the header
  EXPECT_EQ(rows, expected);
  fs::remove_all(dir);
}

// summary.json's accepted counts what the robustness map and results_table count from hops.csv:
// learning trials (alpha > 0) that (36) accepted. The warm-up hops (alpha = 0, reported as
// accepted since (36) does not judge them) are not trials; it counted them (2 vs the map's 1).
TEST(RunLogTest, AcceptedCountsLearningTrialsOnly) {
  Summary alg1;
  const struct {
    double alpha;
    bool accepted;
  } hops[] = {{0.0, true}, {0.0, true}, {1.0, true}, {0.5, false}, {0.5, true}};
  int hop = 0;
  for (const auto& x : hops) {
    plugin::HopReport h;
    h.hop = hop++;
    h.alpha = x.alpha;
    h.accepted = x.accepted;
    h.speed = 0.5;
    alg1.AddHop(h, /*learns=*/true);
  }
  EXPECT_EQ(alg1.accepted, 2);
  EXPECT_EQ(alg1.rejected, 1);
  EXPECT_EQ(alg1.hops, 5);
  EXPECT_DOUBLE_EQ(alg1.mean_speed, 0.5);  // over every hop
  Summary ocfb;
  plugin::HopReport h;
  h.accepted = true;
  ocfb.AddHop(h, /*learns=*/false);
  EXPECT_EQ(ocfb.accepted, 0);
  EXPECT_EQ(ocfb.rejected, 0);
}

// Issue 44: the model terms robots have, as <model> attributes; bad values name the bound.
TEST_F(ScenarioTest, ModelDampingAndSlopeAttributes) {
  const char* body = "<ddoc_scenario>\n<robot mjcf='robot.xml'/>\n%s\n</ddoc_scenario>";
  const Scenario s =
      LoadScenario(Write(Fill(body, "<model b_leg='20' b_hip='0.5' slope='-0.035'/>")));
  ASSERT_TRUE(s.model_numbers.b_leg && s.model_numbers.b_hip && s.model_numbers.slope);
  EXPECT_DOUBLE_EQ(*s.model_numbers.b_leg, 20.0);
  EXPECT_DOUBLE_EQ(*s.model_numbers.b_hip, 0.5);
  EXPECT_DOUBLE_EQ(*s.model_numbers.slope, -0.035);
  ExpectError(Fill(body, "<model b_leg='-1'/>"), {"s.xml:3", "<model>", "b_leg = -1", ">= 0"});
  ExpectError(Fill(body, "<model b_hip='-0.5'/>"), {"s.xml:3", "b_hip = -0.5", ">= 0"});
  ExpectError(Fill(body, "<model slope='0.6'/>"), {"s.xml:3", "slope = 0.6", "(-0.5, 0.5)"});
}

}  // namespace
}  // namespace ddoc::app
