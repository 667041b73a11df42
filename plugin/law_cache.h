// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A directory of stored initial laws u^0. Deriving u^0 (the model-based solve) takes seconds
// (about 7x longer under the sanitizers); a run whose model solve has the same inputs, built
// from the same binaries, can load the stored law instead and steps bitwise as if it had solved.
// docs/design.md, "The law cache".
#ifndef DDOC_PLUGIN_LAW_CACHE_H_
#define DDOC_PLUGIN_LAW_CACHE_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "ddoc/online_controller.h"

namespace ddoc::plugin {

struct ControllerConfig;

/// What the model solve leaves behind for the controller.
struct StoredInitialLaw {
  OnlineControllerLaw law;   ///< u^0 = Learner::ConvergedPolicy(ocfb_alpha) of the model solve
  double model_cost = 0.0;   ///< converged OC-FB cost on the model
  int model_iterations = 0;  ///< trials of the model solve
  /// The model solve's cyclic value (BackwardPass::cyclic_value(), n_0 x n_0; empty: none),
  /// which the robot learner's first pass starts from.
  Matrix cyclic_value;
  /// NominalGait::search of the gait the solve started from: NominalGaitAt rebuilds the gait
  /// without its search (a load then takes milliseconds, not the search's 0.1 s).
  Eigen::Matrix<double, 6, 1> gait_search = Eigen::Matrix<double, 6, 1>::Zero();
};

/// The text that identifies u^0: every ControllerConfig field the model solve reads (doubles as
/// hex floats, so equal text means equal values) and the GNU build ids of the objects that hold
/// the solve's code and the math library. Empty when a build id cannot be read: then nothing is
/// stored or loaded.
std::string InitialLawKey(const ControllerConfig& config);

/// The file of `key` in `dir`: <dir>/u0-<64-bit FNV-1a of key, hex>.law.
std::string InitialLawPath(const std::string& dir, const std::string& key);

/// Reads the law of `key` from `dir`. False with *why ("no file", "checksum mismatch", "stored
/// for another key", ...) when there is no usable law; the file is then left as it is.
bool ReadInitialLaw(const std::string& dir, const std::string& key, StoredInitialLaw* out,
                    std::string* why);

/// The bytes of a law file stored for `key` (what WriteInitialLaw writes): a header, the key, the
/// model cost and trials, the gait's search variables, the law's arrays, then LawFileChecksum of everything before it.
std::string SerializeInitialLaw(const std::string& key, const StoredInitialLaw& law);

/// Parses the bytes of a law file stored for `key`. False with *why when they are not one
/// (checksum, format, key, sizes); the sizes are checked against the length before anything is
/// allocated. The values are ImportLaw's to check.
bool ParseInitialLaw(const std::string& data, const std::string& key, StoredInitialLaw* out,
                     std::string* why);

/// The checksum a law file ends with: the 64-bit FNV-1a of the bytes before it.
std::uint64_t LawFileChecksum(const char* data, std::size_t size);

/// Laws a directory keeps: WriteInitialLaw removes the least recently used beyond this many.
constexpr int kLawCacheCapacity = 64;

/// Writes the law of `key` into `dir` (created if missing) through a temporary file and a rename,
/// so a concurrent reader sees the old file or the whole new one, then removes the least recently
/// used laws (by modification time; a read refreshes it) beyond kLawCacheCapacity: a rebuilt
/// binary keys new laws, so the old ones would pile up. False with *why on failure.
bool WriteInitialLaw(const std::string& dir, const std::string& key, const StoredInitialLaw& law,
                     std::string* why);

}  // namespace ddoc::plugin

#endif  // DDOC_PLUGIN_LAW_CACHE_H_
