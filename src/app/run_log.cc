// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "run_log.h"

#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace ddoc::app {
namespace {

namespace fs = std::filesystem;

std::FILE* OpenOrThrow(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw std::runtime_error("cannot open \"" + path + "\" for writing");
  return f;
}

// JSON has no NaN/Inf: write null for them.
std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", v);
  return buf;
}

}  // namespace

std::string JsonEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out;
}

RunLog::RunLog(const std::string& dir, std::string method) : dir_(dir), method_(std::move(method)) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    throw std::runtime_error("cannot create output directory \"" + dir_ + "\"" +
                             (ec ? ": " + ec.message() : ""));
  }
  hops_ = OpenOrThrow(dir_ + "/hops.csv");
  trajectory_ = OpenOrThrow(dir_ + "/trajectory.csv");
  events_ = OpenOrThrow(dir_ + "/events.csv");
  std::fputs("hop,t_start,t_end,cost,I1,I2,I3,I4,T1,T2,step_length,speed,apex,alpha,accepted,"
             "du2,dT2,method\n", hops_);
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

void RunLog::WriteHop(const HopRecord& h) {
  std::fprintf(hops_,
               "%d,%.6f,%.6f,%.9g,%.9g,%.9g,%.9g,%.9g,%.6f,%.6f,%.6f,%.6f,%.6f,%.6g,%d,%.9g,%.9g,"
               "%s\n",
               h.hop, h.t_start, h.t_end, h.cost, h.i1, h.i2, h.i3, h.i4, h.t1, h.t2,
               h.step_length, h.speed, h.apex, h.alpha, h.accepted ? 1 : 0, h.du2, h.dt2,
               method_.c_str());
  Flush();
}

void RunLog::WriteSample(const SampleRecord& s) {
  std::fprintf(trajectory_, "%.6f,%d,%d", s.t, s.hop, s.phase);
  for (double v : s.q) std::fprintf(trajectory_, ",%.7g", v);
  for (double v : s.u) std::fprintf(trajectory_, ",%.7g", v);
  std::fprintf(trajectory_, ",%.4g\n", s.push);
}

void RunLog::WriteEvent(const EventRecord& e) {
  std::fprintf(events_, "%.6f,%d,%s,%.6f,%.6f,%.6f,%.6f\n", e.t, e.hop, e.type.c_str(), e.x, e.y,
               e.xd, e.yd);
  Flush();
}

void RunLog::Flush() {
  for (std::FILE* f : {hops_, trajectory_, events_}) std::fflush(f);
}

void RunLog::WriteSummary(const Summary& s) {
  const std::string tmp = dir_ + "/summary.json.tmp";
  std::FILE* f = OpenOrThrow(tmp);
  std::fprintf(f, "{\n");
  std::fprintf(f, "  \"scenario\": \"%s\",\n", JsonEscape(s.scenario).c_str());
  std::fprintf(f, "  \"method\": \"%s\",\n", JsonEscape(s.method).c_str());
  std::fprintf(f, "  \"robot\": \"%s\",\n", JsonEscape(s.robot).c_str());
  std::fprintf(f, "  \"model\": \"%s\",\n", JsonEscape(s.model).c_str());
  std::fprintf(f, "  \"hops\": %d,\n", s.hops);
  std::fprintf(f, "  \"fell\": %s,\n", s.fell ? "true" : "false");
  std::fprintf(f, "  \"fall_reason\": \"%s\",\n", JsonEscape(s.fall_reason).c_str());
  if (s.converged_hop >= 0) {
    std::fprintf(f, "  \"converged_hop\": %d,\n", s.converged_hop);
  } else {
    std::fprintf(f, "  \"converged_hop\": null,\n");
  }
  if (s.stopped_hop >= 0) {
    std::fprintf(f, "  \"stopped_hop\": %d,\n", s.stopped_hop);
  } else {
    std::fprintf(f, "  \"stopped_hop\": null,\n");
  }
  std::fprintf(f, "  \"learner_status\": \"%s\",\n", JsonEscape(s.learner_status).c_str());
  std::fprintf(f, "  \"final_cost\": %s,\n", JsonNumber(s.final_cost).c_str());
  std::fprintf(f, "  \"final_I4\": %s,\n", JsonNumber(s.final_i4).c_str());
  std::fprintf(f, "  \"mean_speed\": %s,\n", JsonNumber(s.mean_speed).c_str());
  std::fprintf(f, "  \"mean_period\": %s,\n", JsonNumber(s.mean_period).c_str());
  std::fprintf(f, "  \"accepted\": %d,\n", s.accepted);
  std::fprintf(f, "  \"rejected\": %d,\n", s.rejected);
  std::fprintf(f, "  \"sim_time_s\": %s,\n", JsonNumber(s.sim_time_s).c_str());
  std::fprintf(f, "  \"wall_time_s\": %s,\n", JsonNumber(s.wall_time_s).c_str());
  std::fprintf(f, "  \"pushes\": [");
  for (size_t i = 0; i < s.pushes.size(); ++i) {
    std::fprintf(f, "%s{\"t\": %s, \"force\": %s, \"duration\": %s}", i ? ", " : "",
                 JsonNumber(s.pushes[i].time).c_str(), JsonNumber(s.pushes[i].force).c_str(),
                 JsonNumber(s.pushes[i].duration).c_str());
  }
  std::fprintf(f, "]\n}\n");
  std::fclose(f);
  std::error_code ec;
  fs::rename(tmp, dir_ + "/summary.json", ec);
  if (ec) throw std::runtime_error("cannot write \"" + dir_ + "/summary.json\": " + ec.message());
}

}  // namespace ddoc::app
