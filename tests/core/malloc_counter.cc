// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "malloc_counter.h"

#include <atomic>
#include <cstddef>
#include <cstdlib>

// Under AddressSanitizer (DDOC_SANITIZE) the sanitizer owns malloc and interposing it aborts the
// process; the counter then uses the sanitizer's allocation hook, which sees every allocation
// (malloc, calloc, realloc, new) as the interposition does.
#if defined(__SANITIZE_ADDRESS__)
#define DDOC_COUNT_WITH_SANITIZER_HOOK 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define DDOC_COUNT_WITH_SANITIZER_HOOK 1
#endif
#endif

#ifdef DDOC_COUNT_WITH_SANITIZER_HOOK
extern "C" int __sanitizer_install_malloc_and_free_hooks(
    void (*malloc_hook)(const volatile void*, size_t), void (*free_hook)(const volatile void*));
#else
extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t n, size_t size);
void* __libc_realloc(void* p, size_t size);
}
#endif

namespace {
std::atomic<long> g_allocations{0};
std::atomic<int> g_active{0};
void Count() {
  if (g_active.load(std::memory_order_relaxed) > 0) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
}
}  // namespace

#ifdef DDOC_COUNT_WITH_SANITIZER_HOOK
namespace {
void OnMalloc(const volatile void*, size_t) { Count(); }
void OnFree(const volatile void*) {}
// Both hooks must be given (a null one makes the installation fail); the probe of
// MallocCountingWorks() fails the allocation tests if it did not work.
[[maybe_unused]] const int g_hooks_installed =
    __sanitizer_install_malloc_and_free_hooks(&OnMalloc, &OnFree);
}  // namespace
#else
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
#endif

namespace ddoc {
namespace testing {

MallocCounter::MallocCounter() : start_(g_allocations.load()) { ++g_active; }
MallocCounter::~MallocCounter() { --g_active; }
long MallocCounter::count() const { return g_allocations.load() - start_; }

void* volatile g_sink = nullptr;

void Escape(void* p) { g_sink = p; }

bool MallocCountingWorks() {
  MallocCounter counter;
  // Through a volatile function pointer so the compiler cannot elide the pair.
  void* (*volatile allocate)(size_t) = &std::malloc;
  void* p = allocate(64);
  Escape(p);
  std::free(p);
  return counter.count() >= 1;
}

}  // namespace testing
}  // namespace ddoc
