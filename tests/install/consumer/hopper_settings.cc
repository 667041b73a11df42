// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The hopper's learner settings from the installed package: the engine's default plus the
// hopper's overrides (ddoc/hopper/hopper_learning.h).
#include <cstdio>

#include <ddoc/hopper/hopper_learning.h>

int main() {
  const ddoc::TrialDriverSettings s = ddoc::HopperTrialSettings();
  std::printf("hopper: %d warm-up hops, c = %g, alpha_initial = %g, mu = %g, restart at %g\n",
              s.warmup_trials, s.learner.c, s.learner.alpha_initial, s.learner.regularization_min,
              s.learner.restart_alpha);
  return s.warmup_trials == 1 && s.learner.c == 1e-4 &&
                 s.learner.alpha_after_accept == ddoc::AlphaAfterAccept::kRatio &&
                 s.learner.restart_on_failure
             ? 0
             : 1;
}
