// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "malloc_counter.h"

#include <atomic>
#include <cstddef>
#include <cstdlib>

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t n, size_t size);
void* __libc_realloc(void* p, size_t size);
}

namespace {
std::atomic<long> g_allocations{0};
std::atomic<int> g_active{0};
void Count() {
  if (g_active.load(std::memory_order_relaxed) > 0) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
}
}  // namespace

extern "C" {
void* malloc(size_t size) {
  Count();
  return __libc_malloc(size);
}
void* calloc(size_t n, size_t size) {
  Count();
  return __libc_calloc(n, size);
}
void* realloc(void* p, size_t size) {
  Count();
  return __libc_realloc(p, size);
}
}

namespace ddoc {
namespace testing {

MallocCounter::MallocCounter() : start_(g_allocations.load()) { ++g_active; }
MallocCounter::~MallocCounter() { --g_active; }
long MallocCounter::count() const { return g_allocations.load() - start_; }

void* volatile g_sink = nullptr;

bool MallocCountingWorks() {
  MallocCounter counter;
  // Through a volatile function pointer so the compiler cannot elide the pair.
  void* (*volatile allocate)(size_t) = &std::malloc;
  g_sink = allocate(64);
  std::free(g_sink);
  return counter.count() >= 1;
}

}  // namespace testing
}  // namespace ddoc
