// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Umbrella header of the ddoc engine.
#ifndef DDOC_DDOC_H_
#define DDOC_DDOC_H_

#include "ddoc/autodiff.h"
#include "ddoc/backward_pass.h"
#include "ddoc/box_qp.h"
#include "ddoc/check_derivatives.h"
#include "ddoc/cost.h"
#include "ddoc/learner.h"
#include "ddoc/linear_system.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "ddoc/quadratic_cost.h"
#include "ddoc/return_map.h"
#include "ddoc/sample_layout.h"
#include "ddoc/switched_system.h"
#include "ddoc/switching_time_update.h"
#include "ddoc/time_normalization.h"
#include "ddoc/trajectory.h"
#include "ddoc/trial_driver.h"
#include "ddoc/types.h"

#endif  // DDOC_DDOC_H_
