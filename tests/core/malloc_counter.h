// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Counts heap allocations (malloc/calloc/realloc/new) of the whole test process by
// interposing glibc's malloc family (Drake LimitMalloc-style); under AddressSanitizer, through
// the sanitizer's allocation hook instead.
#ifndef DDOC_TESTS_CORE_MALLOC_COUNTER_H_
#define DDOC_TESTS_CORE_MALLOC_COUNTER_H_

namespace ddoc {
namespace testing {

/// Allocations counted while at least one MallocCounter is alive.
class MallocCounter {
 public:
  MallocCounter();
  ~MallocCounter();
  /// Allocations since construction.
  long count() const;

 private:
  long start_;
};

/// True when the interposition works in this process (a probe allocation was counted).
bool MallocCountingWorks();

/// Stores p in a volatile sink, so the compiler cannot elide the allocation that made it (a
/// probe allocation that is never read otherwise may be removed, and not counted).
void Escape(void* p);

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_MALLOC_COUNTER_H_
