#pragma once
// Test-only: replaces the global operator new of ONE test executable (include it from exactly
// one file) to count heap allocations, so that fast paths can be shown to make none.

#include <cstdlib>
#include <new>

namespace sid_test {
inline int g_allocations = 0;
}

// GCC 12 pairs the inlined malloc/free below with library news and warns falsely.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  ++sid_test::g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
