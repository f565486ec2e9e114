// No heap allocation per FIRE step: global operator new is replaced by a counting one for the minimiser test
// binary (counting only while `gCounting` is set). A minimise() call has a fixed overhead (its result's
// strings, the first measurement), so the test compares two calls of different lengths from the same warm
// state: the longer one must not allocate more.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <string>

#include "integrators/fire_minimiser.hpp"
#include "tests/integrators/minimise_scenes.hpp"

namespace {
std::atomic<bool> gCounting{false};
std::atomic<long> gAllocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (gCounting.load(std::memory_order_relaxed)) gAllocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace polydem::integrators {
namespace {

long allocationsOf(FireMinimiser& m, std::int64_t steps) {
  m.fireSettings().maxIterations = steps;
  gAllocations = 0;
  gCounting = true;
  const FireResult r = m.minimise();
  gCounting = false;
  EXPECT_FALSE(r.converged);  // the budget, not convergence, ended the call
  return gAllocations.load();
}

TEST(FireMinimiser, DoesNotAllocatePerStep) {
  // Brute force keeps no index (checks the minimiser itself); linked-cell also a backend's build. Both methods:
  // FIRE, and conjugate gradients (its two direction buffers are sized in the first call).
  for (const auto method : {MinimiserMethod::Fire, MinimiserMethod::ConjugateGradient}) {
    for (const char* backend : {"brute", "linked-cell"}) {
      SCOPED_TRACE(std::string(backend) + " " + methodName(method));
      auto start = test::randomSoftStart(300, 0.66, 9);
      MinimiserSettings s = test::harmonicSettings(backend);
      s.method = method;
      s.skin = 0.02;  // frequent rebuilds
      s.fire.forceTolerance = 1e-15;
      FireMinimiser m(std::move(start.particles), start.box, s);
      m.fireSettings().maxIterations = 3000;
      m.minimise();  // buffers reach their working size
      const long shortCall = allocationsOf(m, 200);
      const long longCall = allocationsOf(m, 2000);
      EXPECT_EQ(longCall, shortCall) << "allocations grow with the number of steps";
    }
  }
}

}  // namespace
}  // namespace polydem::integrators
