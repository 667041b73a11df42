// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "run_log.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace ddoc::app {
namespace {

namespace fs = std::filesystem;

std::string Reason(int error) { return error != 0 ? std::strerror(error) : "write error"; }

std::FILE* OpenOrThrow(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    throw RunLogError("cannot open \"" + path + "\" for writing: " + Reason(errno));
  }
  return f;
}


// -1 (not yet) is written as null.
nlohmann::json HopOrNull(int hop) { return hop >= 0 ? nlohmann::json(hop) : nlohmann::json(); }

}  // namespace

void Summary::AddHop(const plugin::HopReport& h, bool learns) {
  hops = h.hop + 1;
  final_cost = h.cost;
  final_i4 = h.terms.i4;
  // Learning trials only (alpha > 0): the warm-up hops, OC-FB and the re-runs of u^0 run the law
  // of alpha = 0, which (36) does not judge. The robustness map and results_table count the same.
  // Re-runs of the nominal's law (remeasured) are not trials.
  if (learns && h.alpha > 0 && !h.remeasured) (h.accepted ? accepted : rejected) += 1;
  ++counted_;
  restarts += h.restarted ? 1 : 0;
  remeasured += h.remeasured ? 1 : 0;
  reverted += h.reverted ? 1 : 0;
  if (converged_hop < 0 && h.status == LearnerStatus::kConverged) converged_hop = h.hop;
  if (stopped_hop < 0 && h.status == LearnerStatus::kLineSearchFailed) stopped_hop = h.hop;
  learner_status = learns ? LearnerStatusName(h.status) : "none";
  speed_sum_ += h.speed;
  period_sum_ += h.t2;
  const int n = counted_;
  mean_speed = speed_sum_ / n;
  mean_period = period_sum_ / n;
  identified_mass = h.identified_mass;
  model_mass = h.model_mass;
  identified_terms = h.identified_terms;
  model_params = h.model_params;
  if (std::isfinite(h.stance_mass)) {
    stance_mass_sum_ += h.stance_mass;
    mean_stance_mass = stance_mass_sum_ / ++stance_mass_hops_;
  }
  if (std::isfinite(h.offline_ms)) {
    offline_ms_.push_back(h.offline_ms);
    offline_max_ms = std::max(std::isnan(offline_max_ms) ? 0.0 : offline_max_ms, h.offline_ms);
    std::vector<double> sorted = offline_ms_;
    const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
    std::nth_element(sorted.begin(), mid, sorted.end());
    offline_median_ms = *mid;
    // A law that this computer made later than the simulated latency.
    if (std::isfinite(h.latency_ms) && h.offline_ms > h.latency_ms) ++late_hops;
  }
  if (std::isfinite(h.latency_ms)) {
    latency_max_ms = std::max(std::isnan(latency_max_ms) ? 0.0 : latency_max_ms, h.latency_ms);
  }
}

RunLog::RunLog(const std::string& dir, std::string method) : dir_(dir), method_(std::move(method)) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    throw RunLogError("cannot create output directory \"" + dir_ + "\"" +
                             (ec ? ": " + ec.message() : ""));
  }
  hops_ = OpenOrThrow(dir_ + "/hops.csv");
  trajectory_ = OpenOrThrow(dir_ + "/trajectory.csv");
  events_ = OpenOrThrow(dir_ + "/events.csv");
  std::fputs("hop,t_start,t_end,cost,I1,I2,I3,I4,T1,T2,step_length,speed,apex,alpha,accepted,"
             "du2,dT2,method,start_shift,restarted,remeasured,learner_cost,nominal_cost,predicted,"
             "optimality,stance_mass,reverted,identified_mass,model_mass,latched\n", hops_);
  std::fputs("t,hop,phase,x,y,theta,phi,r,k_hip,k_leg,xd,yd,thetad,phid,rd,kd_hip,kd_leg,"
             "tau0,F0,k0_hip,k0_leg,push\n", trajectory_);
  std::fputs("t,hop,type,x,y,xd,yd\n", events_);
  Flush();
}

RunLog::~RunLog() {
  for (std::FILE* f : {hops_, trajectory_, events_}) {
    if (f != nullptr) std::fclose(f);
  }
}

void RunLog::Check(std::FILE* f, const char* name, bool ok) {
  if (ok && !std::ferror(f)) return;
  const int error = errno;
  throw RunLogError("cannot write \"" + dir_ + "/" + name + "\": " + Reason(error));
}

void RunLog::WriteHop(const plugin::HopReport& h) {
  errno = 0;
  const int n = std::fprintf(hops_,
               "%d,%.6f,%.6f,%.9g,%.9g,%.9g,%.9g,%.9g,%.6f,%.6f,%.6f,%.6f,%.6f,%.6g,%d,%.9g,%.9g,"
               "%s,%.9g,%d,%d,%.9g,%.9g,%.9g,%.9g,%.6f,%d,%.6f,%.6f,%d\n",
               h.hop, h.t_start, h.t_end, h.cost, h.terms.i1, h.terms.i2, h.terms.i3, h.terms.i4,
               h.t1, h.t2, h.step_length, h.speed, h.apex, h.alpha, h.accepted ? 1 : 0, h.du2,
               h.dt2, method_.c_str(), h.start_shift, h.restarted ? 1 : 0,
               h.remeasured ? 1 : 0, h.learner_cost, h.nominal_cost, h.predicted, h.optimality,
               h.stance_mass, h.reverted ? 1 : 0, h.identified_mass, h.model_mass,
               h.reference_latched ? 1 : 0);
  Check(hops_, "hops.csv", n >= 0 && std::fflush(hops_) == 0);
}

namespace {

// A trajectory.csv row, formatted with std::to_chars: the text of printf's "%.6f" and "%.Pg"
// (the standard defines to_chars with a precision as printf's conversion), several times faster
// than fprintf for the ~100,000 rows of a run.
class Row {
 public:
  void Fixed(double v, int precision) { Put(v, std::chars_format::fixed, precision); }
  void General(double v, int precision) { Put(v, std::chars_format::general, precision); }
  void Int(int v) { end_ = std::to_chars(end_, buf_ + sizeof(buf_), v).ptr; }
  void Char(char c) { *end_++ = c; }
  const char* data() const { return buf_; }
  std::size_t size() const { return static_cast<std::size_t>(end_ - buf_); }

 private:
  void Put(double v, std::chars_format f, int precision) {
    end_ = std::to_chars(end_, buf_ + sizeof(buf_), v, f, precision).ptr;
  }
  // 3 + 24 numbers of at most ~330 characters ("%.6f" of 1e308) each.
  char buf_[27 * 340];
  char* end_ = buf_;
};

}  // namespace

void RunLog::WriteSample(const SampleRecord& s) {
  errno = 0;
  Row row;
  row.Fixed(s.t, 6);
  row.Char(',');
  row.Int(s.hop);
  row.Char(',');
  row.Int(s.phase);
  for (double v : s.q) {
    row.Char(',');
    row.General(v, 7);
  }
  for (double v : s.u) {
    row.Char(',');
    row.General(v, 7);
  }
  row.Char(',');
  row.General(s.push, 4);
  row.Char('\n');
  const bool ok = std::fwrite(row.data(), 1, row.size(), trajectory_) == row.size();
  Check(trajectory_, "trajectory.csv", ok);
}

void RunLog::WriteEvent(const EventRecord& e) {
  errno = 0;
  const int n = std::fprintf(events_, "%.6f,%d,%s,%.6f,%.6f,%.6f,%.6f\n", e.t, e.hop,
                             e.type.c_str(), e.x, e.y, e.xd, e.yd);
  Check(events_, "events.csv", n >= 0);
  Flush();
}

void RunLog::Flush() {
  errno = 0;
  Check(hops_, "hops.csv", std::fflush(hops_) == 0);
  Check(events_, "events.csv", std::fflush(events_) == 0);
  Check(trajectory_, "trajectory.csv", std::fflush(trajectory_) == 0);
}

void RunLog::FlushQuietly() noexcept {
  for (std::FILE* f : {hops_, trajectory_, events_}) {
    if (f != nullptr) std::fflush(f);
  }
}

void RunLog::WriteSummary(const Summary& s) {
  nlohmann::ordered_json j;
  j["scenario"] = s.scenario;
  j["method"] = s.method;
  j["robot"] = s.robot;
  j["model"] = s.model;
  j["offline_latency_s"] = s.offline_latency_s;
  j["offline_latency_measured"] = s.offline_latency_measured;
  j["offline_latency_mode"] = s.offline_latency_mode;
  j["initial_law"] = s.initial_law;
  j["hops"] = s.hops;
  j["fell"] = s.fell;
  j["fall_reason"] = s.fall_reason;
  j["converged_hop"] = HopOrNull(s.converged_hop);
  j["stopped_hop"] = HopOrNull(s.stopped_hop);
  j["learner_status"] = s.learner_status;
  j["final_cost"] = s.final_cost;  // JSON has no NaN/Inf: nlohmann writes null for them
  j["final_I4"] = s.final_i4;
  j["mean_speed"] = s.mean_speed;
  j["mean_period"] = s.mean_period;
  j["mean_stance_mass"] = s.mean_stance_mass;  // null when no hop had a stance_mass
  j["identification"] = {{"mass", s.identify_mass},
                         {"identified_mass", s.identified_mass},
                         {"model_mass", s.model_mass},
                         {"terms", s.identify_terms},
                         {"terms_acted", s.identify_terms_acted},
                         {"resolves", nlohmann::json::array()}};
  const TermsIdentification::Estimate& e = s.identified_terms;
  const HopperParams& p = s.model_params;
  for (const auto& [name, term, model] :  // value null: not measured yet; se null: not determined
       {std::tuple{"b_leg", &e.b_leg, p.b_leg}, {"b_hip", &e.b_hip, p.b_hip},
        {"j_body", &e.j_body, p.J_body}, {"c_d", &e.c_d, p.c_d}, {"slope", &e.slope, p.slope}}) {
    j["identification"][std::string("identified_") + name] = {
        {"value", term->value}, {"se", term->se}, {"hops", term->samples},
        {"rejected", term->rejected}};
    j["identification"][std::string("model_") + name] = model;
  }
  for (const plugin::ModelResolve& r : s.resolves) {
    nlohmann::ordered_json resolve = {{"hop", r.hop}};
    for (const auto& [name, value] : plugin::ResolvedTerms(r.model)) resolve[name] = value;
    resolve["took_over_hop"] = HopOrNull(r.took_over_hop);
    resolve["initialize_hop"] = HopOrNull(r.initialize_hop);
    resolve["wall_ms"] = r.wall_ms;
    resolve["initial_law"] = r.law_cache;
    j["identification"]["resolves"].push_back(resolve);
  }
  j["accepted"] = s.accepted;
  j["restarts"] = s.restarts;
  j["remeasured"] = s.remeasured;
  j["reverted"] = s.reverted;
  j["rejected"] = s.rejected;
  j["sim_time_s"] = s.sim_time_s;
  j["wall_time_s"] = s.wall_time_s;
  j["offline_timing"] = {{"max_ms", s.offline_max_ms},
                         {"median_ms", s.offline_median_ms},
                         {"late_hops", s.late_hops},
                         {"latency_max_ms", s.latency_max_ms}};
  j["end"] = s.end;
  j["end_message"] = s.end_message;
  j["pushes"] = nlohmann::json::array();
  for (const Push& p : s.pushes) {
    j["pushes"].push_back({{"t", p.time}, {"force", p.force}, {"duration", p.duration}});
  }
  j["hop_pushes"] = nlohmann::json::array();
  for (size_t i = 0; i < s.hop_pushes.size(); ++i) {
    const HopPush& p = s.hop_pushes[i];
    const bool resolved = i < s.hop_push_times.size() && s.hop_push_times[i];
    j["hop_pushes"].push_back({{"hop", p.hop},
                               {"phase", p.phase},
                               {"force", p.force},
                               {"duration", p.duration},
                               {"t", resolved ? nlohmann::json(*s.hop_push_times[i])
                                              : nlohmann::json()}});
  }
  const std::string tmp = dir_ + "/summary.json.tmp";
  {
    errno = 0;
    std::ofstream out(tmp);
    out << j.dump(2) << "\n";
    out.flush();
    if (!out) throw RunLogError("cannot write \"" + tmp + "\": " + Reason(errno));
  }
  std::error_code ec;
  fs::rename(tmp, dir_ + "/summary.json", ec);
  if (ec) throw RunLogError("cannot write \"" + dir_ + "/summary.json\": " + ec.message());
}

}  // namespace ddoc::app
