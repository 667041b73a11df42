// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "law_cache.h"

#include <dlfcn.h>
#include <link.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>
#include <vector>

#include "hopper_controller.h"

namespace ddoc::plugin {
namespace {

constexpr char kMagic[8] = {'D', 'D', 'O', 'C', 'L', 'A', 'W', '\n'};
constexpr std::uint32_t kFormat = 3;  // 2: the cyclic value after the law; 3: and the gait search

// A field added to one of these structs must be added to InitialLawKey below (or stated there as
// not read by the model solve); the sizes are those of x86-64 with libstdc++.
#if defined(__x86_64__) && defined(__GLIBCXX__)
static_assert(sizeof(HopperParams) == 88, "HopperParams changed: update InitialLawKey");
static_assert(sizeof(HopperCostWeights) == 160, "HopperCostWeights changed: update InitialLawKey");
static_assert(sizeof(NominalGaitSettings) == 56, "NominalGaitSettings changed: update the key");
static_assert(sizeof(HopperModeDurations) == 32, "HopperModeDurations changed: update the key");
static_assert(sizeof(BackwardPassSettings) == 56, "BackwardPassSettings changed: update the key");
static_assert(sizeof(SwitchingTimeSettings) == 16, "SwitchingTimeSettings changed: update the key");
static_assert(sizeof(BoxQPSettings) == 48, "BoxQPSettings changed: update InitialLawKey");
static_assert(sizeof(OnlineControllerSettings) == 80, "OnlineControllerSettings changed: update");
static_assert(sizeof(LearnerSettings) == 328, "LearnerSettings changed: update InitialLawKey");
#endif

std::uint64_t Fnv1a(const char* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ULL) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ULL;
  }
  return h;
}

// "name=value\n" lines; doubles as hex floats (exact).
class KeyText {
 public:
  void D(const std::string& name, double v) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%a", v);
    Line(name, buf);
  }
  void I(const std::string& name, long v) { Line(name, std::to_string(v)); }
  void B(const std::string& name, bool v) { Line(name, v ? "1" : "0"); }
  void V(const std::string& name, const Eigen::Ref<const Vector>& v) {
    I(name + ".size", static_cast<long>(v.size()));
    for (Eigen::Index i = 0; i < v.size(); ++i) D(name + "[" + std::to_string(i) + "]", v(i));
  }
  void Line(const std::string& name, const std::string& value) {
    text_ += name;
    text_ += '=';
    text_ += value;
    text_ += '\n';
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

struct BuildIdQuery {
  std::uintptr_t address = 0;
  bool found = false;  // an object holds the address
  std::string id;      // its GNU build id in hex ("" if it has none)
};

// The GNU build id of the loaded object whose PT_LOAD segments hold query->address.
int FindBuildId(dl_phdr_info* info, std::size_t, void* data) {
  auto* q = static_cast<BuildIdQuery*>(data);
  bool holds = false;
  for (int i = 0; i < info->dlpi_phnum && !holds; ++i) {
    const ElfW(Phdr)& p = info->dlpi_phdr[i];
    const std::uintptr_t start = info->dlpi_addr + p.p_vaddr;
    holds = p.p_type == PT_LOAD && q->address >= start && q->address < start + p.p_memsz;
  }
  if (!holds) return 0;
  q->found = true;
  for (int i = 0; i < info->dlpi_phnum; ++i) {
    const ElfW(Phdr)& p = info->dlpi_phdr[i];
    if (p.p_type != PT_NOTE) continue;
    const std::size_t align = p.p_align >= 8 ? 8 : 4;
    auto up = [align](std::size_t n) { return (n + align - 1) / align * align; };
    const char* note = reinterpret_cast<const char*>(info->dlpi_addr + p.p_vaddr);
    std::size_t pos = 0;
    while (pos + sizeof(ElfW(Nhdr)) <= p.p_memsz) {
      ElfW(Nhdr) header;
      std::memcpy(&header, note + pos, sizeof(header));
      const std::size_t name_at = pos + sizeof(header);
      const std::size_t desc_at = name_at + up(header.n_namesz);
      if (desc_at + header.n_descsz > p.p_memsz) break;
      if (header.n_type == NT_GNU_BUILD_ID && header.n_namesz == 4 &&
          std::memcmp(note + name_at, "GNU", 4) == 0) {
        static const char* hex = "0123456789abcdef";
        for (std::size_t b = 0; b < header.n_descsz; ++b) {
          const auto byte = static_cast<unsigned char>(note[desc_at + b]);
          q->id += hex[byte >> 4];
          q->id += hex[byte & 15];
        }
        return 1;
      }
      pos = desc_at + up(header.n_descsz);
    }
  }
  return 1;
}

std::string BuildIdAt(const void* address) {
  BuildIdQuery q;
  q.address = reinterpret_cast<std::uintptr_t>(address);
  dl_iterate_phdr(FindBuildId, &q);
  return q.id;
}

void AddLearnerSettings(const LearnerSettings& s, KeyText* k) {
  k->I("learner.acceptance", static_cast<int>(s.acceptance));
  k->D("learner.c", s.c);
  k->D("learner.gamma", s.gamma);
  k->B("learner.interpolate_backtracking", s.interpolate_backtracking);
  k->D("learner.alpha_initial", s.alpha_initial);
  k->I("learner.alpha_after_accept", static_cast<int>(s.alpha_after_accept));
  k->D("learner.alpha_min", s.alpha_min);
  k->D("learner.convergence_tolerance", s.convergence_tolerance);
  k->B("learner.step_convergence", s.step_convergence);
  k->D("learner.epsilon", s.epsilon);
  k->I("learner.delta_i", s.delta_i);
  k->D("learner.optimality_tolerance", s.optimality_tolerance);
  k->D("learner.regularization_min", s.regularization_min);
  k->I("learner.failure_raises", s.failure_raises);
  k->D("learner.curvature_scale_min", s.curvature_scale_min);
  k->B("learner.start_correction", s.start_correction);
  if (s.reference_shift) k->B("learner.reference_shift", true);  // keys of older caches hold
  k->B("learner.restart_on_failure", s.restart_on_failure);
  k->D("learner.restart_alpha", s.restart_alpha);
  k->B("learner.remeasure_nominal", s.remeasure_nominal);
  k->D("learner.noise_margin", s.noise_margin);
  k->B("learner.blend_feedback", s.blend_feedback);
  if (s.blend_feedforward) k->B("learner.blend_feedforward", true);  // older keys hold
  if (s.min_predicted_decrease != 0.0) {
    k->D("learner.min_predicted_decrease", s.min_predicted_decrease);
  }
  k->I("learner.max_trials", s.max_trials);
  k->I("learner.max_samples", s.max_samples);
  const BackwardPassSettings& b = s.backward;
  k->I("backward.equation", static_cast<int>(b.equation));
  k->I("backward.integrator", static_cast<int>(b.integrator));
  k->B("backward.box_aware", b.box_aware);
  k->B("backward.time_curvature", b.time_curvature);
  k->B("backward.use_previous_du", b.use_previous_du);
  k->B("backward.psd_switching_hessians", b.psd_switching_hessians);
  k->I("backward.max_substeps", b.max_substeps);
  k->I("backward.min_substeps", b.min_substeps);
  k->D("backward.cyclic_value", b.cyclic_value);
  k->I("backward.cyclic_max_sweeps", b.cyclic_max_sweeps);
  k->D("backward.cyclic_tolerance", b.cyclic_tolerance);
  k->B("backward.terminal_event", b.terminal_event);
  k->B("backward.keep_P_trajectory", b.keep_P_trajectory);
  k->D("switching.relative_regularization", s.switching.relative_regularization);
  k->D("switching.max_duration_step", s.switching.max_duration_step);
  const OnlineControllerSettings& c = s.controller;
  k->B("controller.interpolate", c.interpolate);
  k->B("controller.warm_start", c.warm_start);
  k->I("controller.state_feedback_scale.size", static_cast<long>(c.state_feedback_scale.size()));
  for (std::size_t i = 0; i < c.state_feedback_scale.size(); ++i) {
    k->V("controller.state_feedback_scale[" + std::to_string(i) + "]", c.state_feedback_scale[i]);
  }
  k->I("qp.max_iterations", c.qp.max_iterations);
  k->D("qp.tolerance", c.qp.tolerance);
  k->D("qp.armijo", c.qp.armijo);
  k->D("qp.backtrack", c.qp.backtrack);
  k->I("qp.max_line_search_steps", c.qp.max_line_search_steps);
  k->D("qp.active_set_margin", c.qp.active_set_margin);
}

// Little-endian fixed-size fields; the build ids in the key pin the platform.
template <class T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
void PutArray(std::string* out, const double* v, Eigen::Index n) {
  if (n == 0) return;  // v may be null
  out->append(reinterpret_cast<const char*>(v), static_cast<std::size_t>(n) * sizeof(double));
}

class Reader {
 public:
  explicit Reader(const std::string& data, std::size_t end) : data_(data), end_(end) {}
  template <class T>
  bool Get(T* v) {
    return Raw(v, sizeof(T));
  }
  bool Array(double* v, Eigen::Index n) {
    return Raw(v, static_cast<std::size_t>(n) * sizeof(double));
  }
  bool Raw(void* dst, std::size_t n) {
    if (n > end_ - pos_) return false;
    if (n == 0) return true;  // an empty array's data() may be null: no memcpy
    std::memcpy(dst, data_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  bool done() const { return pos_ == end_; }
  std::size_t remaining() const { return end_ - pos_; }

 private:
  const std::string& data_;
  std::size_t end_;
  std::size_t pos_ = 0;
};

}  // namespace

std::string SerializeInitialLaw(const std::string& key, const StoredInitialLaw& s) {
  const OnlineControllerLaw& l = s.law;
  std::string out(kMagic, sizeof(kMagic));
  Put(&out, kFormat);
  Put(&out, static_cast<std::uint64_t>(key.size()));
  out += key;
  Put(&out, s.model_cost);
  Put(&out, static_cast<std::int32_t>(s.model_iterations));
  PutArray(&out, s.gait_search.data(), s.gait_search.size());
  Put(&out, l.alpha);
  Put(&out, l.feedback_factor);
  const auto K = static_cast<std::int32_t>(l.samples.size());
  Put(&out, K);
  for (int N : l.samples) Put(&out, static_cast<std::int32_t>(N));
  PutArray(&out, l.dT.data(), l.dT.size());
  PutArray(&out, l.nominal_T.data(), l.nominal_T.size());
  Put(&out, static_cast<std::int32_t>(l.x.rows()));
  Put(&out, static_cast<std::int32_t>(l.u.rows()));
  PutArray(&out, l.tau.data(), l.tau.size());
  for (const Matrix* a : {&l.x, &l.u, &l.Kx, &l.c, &l.huu}) PutArray(&out, a->data(), a->size());
  Put(&out, static_cast<std::int32_t>(s.cyclic_value.rows()));
  PutArray(&out, s.cyclic_value.data(), s.cyclic_value.size());
  Put(&out, LawFileChecksum(out.data(), out.size()));
  return out;
}

bool ParseInitialLaw(const std::string& data, const std::string& key, StoredInitialLaw* s,
                     std::string* why) {
  auto fail = [why](const char* what) {
    *why = what;
    return false;
  };
  std::uint64_t sum = 0;
  if (data.size() < sizeof(kMagic) + sizeof(sum)) return fail("truncated file");
  const std::size_t body = data.size() - sizeof(sum);
  std::memcpy(&sum, data.data() + body, sizeof(sum));
  if (std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) return fail("not a ddoc law file");
  if (LawFileChecksum(data.data(), body) != sum) {
    return fail("checksum mismatch (truncated or corrupt)");
  }
  Reader r(data, body);
  char magic[sizeof(kMagic)];
  std::uint32_t format = 0;
  std::uint64_t key_size = 0;
  r.Raw(magic, sizeof(magic));
  if (!r.Get(&format) || format != kFormat) return fail("another file format version");
  if (!r.Get(&key_size) || key_size != key.size()) return fail("stored for another key");
  std::string stored_key(key.size(), '\0');
  if (!r.Raw(stored_key.data(), key.size()) || stored_key != key) {
    return fail("stored for another key");
  }
  std::int32_t iterations = 0, K = 0, n_max = 0, m = 0;
  OnlineControllerLaw& l = s->law;
  if (!r.Get(&s->model_cost) || !r.Get(&iterations) ||
      !r.Array(s->gait_search.data(), s->gait_search.size()) || !r.Get(&l.alpha) ||
      !r.Get(&l.feedback_factor) || !r.Get(&K) || K < 1 || K > 64) {
    return fail("bad header");
  }
  s->model_iterations = iterations;
  l.samples.assign(K, 0);
  long S = 0;
  for (int& N : l.samples) {
    std::int32_t v = 0;
    if (!r.Get(&v) || v < 0 || v > (1 << 24)) return fail("bad sample counts");
    N = v;
    S += v;
  }
  l.dT.resize(K);
  l.nominal_T.resize(K);
  if (!r.Array(l.dT.data(), K) || !r.Array(l.nominal_T.data(), K) || !r.Get(&n_max) ||
      !r.Get(&m) || n_max < 1 || n_max > 4096 || m < 1 || m > 4096) {
    return fail("bad sizes");
  }
  // The sizes must account for the rest of the file exactly before anything is allocated: the
  // law's arrays, the cyclic value's size n_0 (int32) and its n_0^2 doubles.
  const std::size_t doubles = static_cast<std::size_t>(S) *
                              (1 + static_cast<std::size_t>(n_max) + m +
                               static_cast<std::size_t>(m) * n_max + m +
                               static_cast<std::size_t>(m) * m);
  if (r.remaining() < sizeof(std::int32_t) ||
      (r.remaining() - sizeof(std::int32_t)) % sizeof(double) != 0) {
    return fail("array sizes do not match the file length");
  }
  const std::size_t cyclic = (r.remaining() - sizeof(std::int32_t)) / sizeof(double) - doubles;
  if (doubles > (r.remaining() - sizeof(std::int32_t)) / sizeof(double) ||
      cyclic > static_cast<std::size_t>(n_max) * n_max) {
    return fail("array sizes do not match the file length");
  }
  l.tau.resize(S);
  l.x.resize(n_max, S);
  l.u.resize(m, S);
  l.Kx.resize(static_cast<Eigen::Index>(m) * n_max, S);
  l.c.resize(m, S);
  l.huu.resize(static_cast<Eigen::Index>(m) * m, S);
  if (!r.Array(l.tau.data(), S)) return fail("truncated arrays");
  for (Matrix* a : {&l.x, &l.u, &l.Kx, &l.c, &l.huu}) {
    if (!r.Array(a->data(), a->size())) return fail("truncated arrays");
  }
  std::int32_t n0 = 0;
  if (!r.Get(&n0) || n0 < 0 || n0 > n_max || static_cast<std::size_t>(n0) * n0 != cyclic) {
    return fail("bad cyclic value");
  }
  s->cyclic_value.resize(n0, n0);
  if (!r.Array(s->cyclic_value.data(), s->cyclic_value.size())) return fail("truncated arrays");
  if (!r.done()) return fail("trailing bytes");
  if (!s->cyclic_value.allFinite()) return fail("non-finite cyclic value");
  if (!std::isfinite(s->model_cost)) return fail("non-finite model cost");
  if (!s->gait_search.allFinite()) return fail("non-finite gait search variables");
  return true;
}

std::uint64_t LawFileChecksum(const char* data, std::size_t size) { return Fnv1a(data, size); }

namespace {

// Removes the oldest u0-*.law files of `dir` beyond kLawCacheCapacity, never `keep`. Errors
// (a file another process removed first, say) are ignored.
void PruneLaws(const std::string& dir, const std::string& keep) {
  namespace fs = std::filesystem;
  std::vector<std::pair<fs::file_time_type, fs::path>> laws;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() != 23 || name.compare(0, 3, "u0-") != 0 ||
        name.compare(name.size() - 4, 4, ".law") != 0 || it->path() == fs::path(keep)) {
      continue;
    }
    std::error_code time_ec;
    const fs::file_time_type t = fs::last_write_time(it->path(), time_ec);
    if (!time_ec) laws.emplace_back(t, it->path());
  }
  const std::size_t others = kLawCacheCapacity - 1;  // and `keep`
  if (laws.size() <= others) return;
  std::sort(laws.begin(), laws.end());  // oldest first
  for (std::size_t i = 0; i + others < laws.size(); ++i) fs::remove(laws[i].second, ec);
}

}  // namespace

std::string InitialLawKey(const ControllerConfig& c) {
  KeyText k;
  k.Line("ddoc initial law", std::to_string(kFormat));
  // The objects that hold the solve's code (the engine and the hopper are linked into the
  // plugin) and the math library.
  double (*exp_fn)(double) = &std::exp;
  double (*sin_fn)(double) = &std::sin;
  const std::string code_id = BuildIdAt(reinterpret_cast<const void*>(&InitialLawKey));
  const std::string exp_id = BuildIdAt(reinterpret_cast<const void*>(exp_fn));
  const std::string sin_id = BuildIdAt(reinterpret_cast<const void*>(sin_fn));
  if (code_id.empty() || exp_id.empty() || sin_id.empty()) return "";
  k.Line("build_id.code", code_id);
  k.Line("build_id.exp", exp_id);
  k.Line("build_id.sin", sin_id);
  const HopperParams& p = c.model;
  k.D("model.M", p.M);
  k.D("model.J_body", p.J_body);
  k.D("model.J_leg", p.J_leg);
  k.D("model.r0", p.r0);
  k.D("model.c_d", p.c_d);
  k.D("model.beta", p.beta);
  k.D("model.g", p.g);
  k.I("model.impact", static_cast<int>(p.impact));
  // Issue 44's terms, keyed only when on: at 0 they are the paper's model (old keys stay valid).
  if (p.b_leg != 0.0) k.D("model.b_leg", p.b_leg);
  if (p.b_hip != 0.0) k.D("model.b_hip", p.b_hip);
  if (p.slope != 0.0) k.D("model.slope", p.slope);
  k.V("cost.q_diag", c.cost_weights.q_diag);
  k.V("cost.r_diag", c.cost_weights.r_diag);
  k.D("cost.energy_weight", c.cost_weights.energy_weight);
  k.D("cost.surface_weight", c.cost_weights.surface_weight);
  const NominalGaitSettings& g = c.gait;
  k.D("gait.forward_speed", g.forward_speed);
  k.D("gait.apex_height", g.apex_height);
  k.D("gait.k0_hip", g.k0_hip);
  k.D("gait.k0_leg", g.k0_leg);
  k.I("gait.max_iterations", g.max_iterations);
  k.I("gait.continuation_stages", g.continuation_stages);
  k.D("gait.dt", g.dt);
  // gait.max_periodicity is not keyed: it only decides whether a gait is an error, not which.
  k.D("durations.flight_min", c.durations.flight_min);
  k.D("durations.flight_max", c.durations.flight_max);
  k.D("durations.stance_min", c.durations.stance_min);
  k.D("durations.stance_max", c.durations.stance_max);
  k.D("ocfb_alpha", c.ocfb_alpha);
  k.D("dt_model", c.dt_model);
  AddLearnerSettings(c.model_learner, &k);
  // Not read by the model solve: driver, contact, max_samples_per_mode, anchor_reference,
  // anchor_weight, reference_filter, overspeed_latch, offline_latency, offline_thread,
  // pitch_experiment, law_cache.
  return k.text();
}

std::string InitialLawPath(const std::string& dir, const std::string& key) {
  char name[40];
  std::snprintf(name, sizeof(name), "u0-%016llx.law",
                static_cast<unsigned long long>(Fnv1a(key.data(), key.size())));
  return (std::filesystem::path(dir) / name).string();
}

bool ReadInitialLaw(const std::string& dir, const std::string& key, StoredInitialLaw* out,
                    std::string* why) {
  const std::string path = InitialLawPath(dir, key);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *why = "no file";
    return false;
  }
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) {
    *why = "read error";
    return false;
  }
  StoredInitialLaw law;
  if (!ParseInitialLaw(data, key, &law, why)) return false;
  *out = std::move(law);
  std::error_code ec;  // recently used: kept longest (a failure only makes it older)
  std::filesystem::last_write_time(path, std::filesystem::file_time_type::clock::now(), ec);
  return true;
}

bool WriteInitialLaw(const std::string& dir, const std::string& key, const StoredInitialLaw& law,
                     std::string* why) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    *why = "cannot create " + dir + ": " + ec.message();
    return false;
  }
  static std::atomic<int> counter{0};
  const std::string path = InitialLawPath(dir, key);
  const std::string tmp =
      path + ".tmp" + std::to_string(getpid()) + "-" + std::to_string(counter++);
  const std::string data = SerializeInitialLaw(key, law);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    out.close();
    if (!out) {
      std::filesystem::remove(tmp, ec);
      *why = "cannot write " + tmp;
      return false;
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    *why = "cannot rename " + tmp + " to " + path;
    return false;
  }
  PruneLaws(dir, path);
  return true;
}

}  // namespace ddoc::plugin
