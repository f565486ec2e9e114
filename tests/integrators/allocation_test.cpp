// No heap allocation inside the time loop once buffers are sized: global operator new is replaced by a
// counting one for this binary (counting only while `gCounting` is set).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <random>
#include <utility>

#include "broadphase/registry.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "polydem/config.hpp"
#include "tests/integrators/dem_scenes.hpp"

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

TEST(TimeLoop, DoesNotAllocateOnceSized) {
  for (const auto& [friction, threads] :
       {std::pair{false, 1}, std::pair{true, 1}, std::pair{false, 2}, std::pair{true, 2}}) {
    if (threads > 1 && !POLYDEM_WITH_OPENMP) continue;
    SCOPED_TRACE(::testing::Message() << (friction ? "frictional, walls" : "frictionless, periodic") << ", " << threads
                                      << " threads");
    Box box;
    std::vector<double> radii;
    for (int i = 0; i < 343; ++i) radii.push_back(1.0 + 0.5 * (i % 3));
    const Boundary b = friction ? Boundary::Wall : Boundary::Periodic;
    ParticleStore p = test::latticeGas(radii, 0.35, box, 4, friction, {b, b, b});
    DemSettings settings;
    settings.contact.stiffness = 1e4;
    settings.contact.restitution = 0.7;
    settings.contact.friction = friction ? 0.5 : 0.0;
    settings.skin = 0.05;  // frequent rebuilds
    settings.stability.checkInterval = 25;
    settings.threads = threads;  // the OpenMP runtime allocates with malloc, not operator new: our buffers only
    assignImpactVelocities(contact::ContactModel(settings.contact), p, 0.02, 1);
    // Brute force keeps no index, so it checks the DEM loop itself (kicks, drift, rebuild into the CSR
    // list, history remap, force kernel, stability checks); linked-cell also checks a backend's build,
    // whose buffers keep their capacity (LinkedCell::doBuild). Other backends own their builds.
    for (const char* backend : {"brute", "linked-cell"}) {
      SCOPED_TRACE(backend);
      settings.broadPhase = backend;
      DemSimulation sim(p, box, settings);
      sim.advance(3000);  // buffers reach their working size
      const std::int64_t rebuilds = sim.rebuilds();
      gAllocations = 0;
      gCounting = true;
      sim.advance(1000);
      gCounting = false;
      EXPECT_GT(sim.rebuilds(), rebuilds + 5);
      EXPECT_EQ(gAllocations.load(), 0);
    }
  }
}

TEST(VerletList, ThreadedRebuildsDoNotAllocateOnceSized) {
  // 5000 spheres: large enough for the threaded linked-cell sort, chunked pair search and CSR fill (the
  // small scene above runs them serially). Chunks keep headroom, so pair counts that fluctuate between
  // rebuilds do not reallocate. The list alone: with thread blocks, the force loop's cross-pair buffers
  // (ContactList::buildBlocks, DemSimulation's cross scratch) still grow whenever a run sets a new maximum
  // of cross pairs, which is theirs to fix, not the build's.
  if (!POLYDEM_WITH_OPENMP) GTEST_SKIP() << "threads need an OpenMP build";
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 5000; ++i) radii.push_back(1.0 + 0.5 * (i % 3));
  ParticleStore p = test::latticeGas(radii, 0.35, box, 4);
  VerletList list(broadphase::makeBroadPhase("linked-cell"), 0.6);
  list.setThreads(2);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> step(-0.1, 0.1);
  // Fresh small displacements from the start each round: a stationary pair count, as in a relaxing packing.
  const Eigen::Matrix3Xd base = p.position();
  auto jiggle = [&] {
    for (Index i = 0; i < p.count(); ++i) {
      for (int k = 0; k < 3; ++k) p.position()(k, i) = base(k, i) + step(rng);
      p.position().col(i) = box.wrap(p.position().col(i));
    }
  };
  for (int round = 0; round < 30; ++round) {
    jiggle();
    list.build(p.spheres(), box);
  }
  ASSERT_GT(list.list().pairCount(), 2000u);
  gAllocations = 0;
  gCounting = true;
  for (int round = 0; round < 20; ++round) {
    jiggle();
    list.build(p.spheres(), box);
  }
  gCounting = false;
  EXPECT_EQ(gAllocations.load(), 0);
}

}  // namespace
}  // namespace polydem::integrators
