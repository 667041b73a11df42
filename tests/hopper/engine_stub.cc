// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// TEMPORARY fallback, compiled ONLY when the engine target ddoc::ddoc does not exist yet (see
// src/hopper/CMakeLists.txt): minimal definitions of the non-virtual SwitchedSystem/SwitchedCost
// methods so the hopper model can be built and tested before src/core lands. Not the engine.
#include <string>

#include "ddoc/switched_system.h"

namespace ddoc {

SwitchedSystem::SwitchedSystem(std::vector<int> state_dims, int input_dim,
                               std::vector<int> surface_dims, bool has_cycle_reset)
    : state_dims_(std::move(state_dims)),
      surface_dims_(std::move(surface_dims)),
      input_dim_(input_dim),
      has_cycle_reset_(has_cycle_reset) {
  if (surface_dims_.empty()) surface_dims_.assign(state_dims_.size(), 0);
}
int SwitchedSystem::state_dim(int k) const { return state_dims_.at(k); }
int SwitchedSystem::surface_dim(int k) const { return surface_dims_.at(k); }
int SwitchedSystem::max_state_dim() const {
  int n = 0;
  for (int d : state_dims_) n = d > n ? d : n;
  return n;
}
void SwitchedSystem::Flow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                          VectorRef xdot) const {
  DoFlow(k, x, u, xdot);
}
void SwitchedSystem::FlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                     MatrixRef fx, MatrixRef fu) const {
  DoFlowDerivatives(k, x, u, fx, fu);
}
void SwitchedSystem::Reset(int k, const ConstVectorRef& x, VectorRef x_next) const {
  DoReset(k, x, x_next);
}
void SwitchedSystem::ResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const {
  DoResetDerivative(k, x, gx);
}
void SwitchedSystem::Surface(int k, const ConstVectorRef& x, VectorRef h) const {
  DoSurface(k, x, h);
}
void SwitchedSystem::SurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const {
  DoSurfaceDerivative(k, x, hx);
}
void SwitchedSystem::DoSurface(int, const ConstVectorRef&, VectorRef) const {}
void SwitchedSystem::DoSurfaceDerivative(int, const ConstVectorRef&, MatrixRef) const {}

double SwitchedCost::Running(int k, const ConstVectorRef& x, const ConstVectorRef& u) const {
  return DoRunning(k, x, u);
}
void SwitchedCost::RunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                      VectorRef lx, VectorRef lu, MatrixRef lxx, MatrixRef luu,
                                      MatrixRef lux) const {
  DoRunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
}
double SwitchedCost::Switching(int k, const ConstVectorRef& x) const { return DoSwitching(k, x); }
void SwitchedCost::SwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                                        MatrixRef phixx) const {
  DoSwitchingDerivatives(k, x, phix, phixx);
}

}  // namespace ddoc
