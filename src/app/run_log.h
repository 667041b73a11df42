// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The output files of one ddoc-hopper run (formats in docs/hopper.md, "Output files").
// Every file is flushed as it grows, and summary.json is rewritten after every hop,
// so a run that falls keeps everything up to the fall. Every write is checked: a failed one
// (full disk, file size limit, output directory gone) throws RunLogError naming the file.
#ifndef DDOC_APP_RUN_LOG_H_
#define DDOC_APP_RUN_LOG_H_

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hop_report.h"
#include "scenario.h"

namespace ddoc::app {

/// A write of the run log failed; the message names the file and the system's reason.
class RunLogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One row of trajectory.csv.
struct SampleRecord {
  double t = 0.0;
  int hop = 0;
  int phase = 0;             // 0 flight, 1 stance
  double q[14] = {};         // x,y,theta,phi,r,k_hip,k_leg and rates (flight coordinates)
  double u[4] = {};          // applied input
  double push = 0.0;         // external horizontal force [N]
};

struct EventRecord {
  double t = 0.0;
  int hop = 0;
  std::string type;          // touchdown|takeoff|push_start|push_end|fall
  double x = 0.0, y = 0.0, xd = 0.0, yd = 0.0;
};

/// summary.json: the run so far.
struct Summary {
  std::string scenario, method, robot, model;
  double offline_latency_s = 0.0;  // ControllerConfig::offline_latency of the run
  bool offline_latency_measured = false;  // ControllerConfig::measured_latency of the run
  // "modeled", "measured" or "fixed" (ControllerConfig::modeled_latency, measured_latency)
  std::string offline_latency_mode = "modeled";
  double latency_max_ms = std::nan("");  // the longest simulated latency of a learned law, ms
  // Wall-clock figures of the offline part (summary.json "offline_timing"; not deterministic):
  // its longest and median hop, and the hops whose law it made later than the simulated latency.
  double offline_max_ms = std::nan(""), offline_median_ms = std::nan("");
  int late_hops = 0;
  std::string initial_law;         // HopperController::law_cache_status()
  int hops = 0;
  bool fell = false;
  std::string fall_reason;
  int converged_hop = -1;    // -1: not converged
  int stopped_hop = -1;      // hop where the line search gave up (alpha < alpha_min); -1: never
  std::string learner_status = "running";  // running | converged | line_search_failed | none
  // NaN (null in summary.json) until a hop is complete.
  double final_cost = std::nan(""), final_i4 = std::nan(""), mean_speed = std::nan(""),
         mean_period = std::nan("");
  double mean_stance_mass = std::nan("");  // kg, over the hops with a stance_mass; NaN: none
  // summary.json "identification": IdentificationSettings::mass of the run, the last hop's
  // estimate and model M (kg), and the re-solves of u^0 (HopperController::resolves()).
  bool identify_mass = false;
  double identified_mass = std::nan(""), model_mass = std::nan("");
  // IdentificationSettings::terms, the last hop's estimates of the terms with their standard
  // errors, and the model's terms (HopReport::identified_terms, model_params).
  bool identify_terms = false;
  std::string identify_terms_acted = "all";  ///< ActedTermsName of the terms acted on
  TermsIdentification::Estimate identified_terms;
  HopperParams model_params;
  std::vector<plugin::ModelResolve> resolves;
  double wall_time_s = 0.0;
  double sim_time_s = 0.0;
  /// Learning trials (hops run with alpha > 0, the ones (36) judges) accepted / rejected: the
  /// warm-up hops, OC-FB and mRL's re-runs of u^0 are neither (tools/ddoc_results.py counts the
  /// same from hops.csv: accepted and alpha > 0).
  int accepted = 0, rejected = 0;
  int restarts = 0;  // hops after which the line search restarted (restart_on_failure)
  int remeasured = 0;  // hops that re-ran the nominal's law (remeasure_nominal, the harm guard)
  int reverted = 0;    // laws the harm guard abandoned
  std::vector<Push> pushes;          // timed pushes, then the hop pushes resolved so far
  std::vector<HopPush> hop_pushes;   // the scenario's pushes by hop phase
  std::vector<std::optional<double>> hop_push_times;  // their start, once resolved
  std::string end = "running";  // running|completed|fell|interrupted|io_error|nonfinite_state|error
  std::string end_message;      // what ended it ("" while running or completed)

  /// Counts a completed hop: hops, final cost and I4, accepted/rejected, the first converged
  /// and line-search-stopped hops, the learner status ("none" when `learns` is false), means.
  void AddHop(const plugin::HopReport& hop, bool learns);

 private:
  double speed_sum_ = 0.0, period_sum_ = 0.0, stance_mass_sum_ = 0.0;
  std::vector<double> offline_ms_;  // per hop handed to the offline part
  int stance_mass_hops_ = 0;
  int counted_ = 0;  // hops added
};

/// Opens DIR/{hops,trajectory,events}.csv (creating DIR) and writes the headers.
class RunLog {
 public:
  /// Throws RunLogError naming the path when the directory cannot be created
  /// or a file cannot be opened.
  explicit RunLog(const std::string& dir, std::string method);
  ~RunLog();
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;

  // Each write below throws RunLogError naming the file when it (or its flush) fails.
  /// Appends and flushes a hop row (hops.csv: one hop is one trial of Algorithm 1); flushes
  /// hops.csv only, so that a failing other file cannot keep a hop out of it.
  void WriteHop(const plugin::HopReport& hop);
  /// Appends a sample; flushed at the next hop or event.
  void WriteSample(const SampleRecord& sample);
  /// Appends and flushes an event (flushes the trajectory too).
  void WriteEvent(const EventRecord& event);
  /// Rewrites summary.json atomically (write to a temporary file, then rename).
  void WriteSummary(const Summary& summary);
  /// Flushes everything.
  void Flush();
  /// Flushes what can still be flushed and never throws (after a failed write, to keep the rest).
  void FlushQuietly() noexcept;

  const std::string& dir() const { return dir_; }

 private:
  // Throws RunLogError for `f` (named `name`) when its error flag is set or `ok` is false.
  void Check(std::FILE* f, const char* name, bool ok);

  std::string dir_;
  std::string method_;
  std::FILE* hops_ = nullptr;
  std::FILE* trajectory_ = nullptr;
  std::FILE* events_ = nullptr;
};

}  // namespace ddoc::app

#endif  // DDOC_APP_RUN_LOG_H_
