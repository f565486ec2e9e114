#include "contact/force_loop.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "broadphase/registry.hpp"
#include "polydem/config.hpp"
#include "tests/support/scene.hpp"

namespace polydem::contact {
namespace {

/// Overlapping random spheres with random velocities and spins, and a brute-force contact list.
struct Fixture {
  test::Scene scene;
  ParticleStore particles;
  ContactList list;
  ContactHistory pairHistory{3}, wallHistory{3};
  Eigen::Matrix3Xd angularVelocity;

  explicit Fixture(bool periodic, double skin = 0.1) {
    scene = test::makeScene({.count = 400,
                             .distribution = "uniform-radius",
                             .sizeRatio = 3.0,
                             .packing = 0.4,
                             .periodic = periodic,
                             .seed = 5});
    particles = ParticleStore(scene.spheres().count(), Features{.rotation = true});
    particles.position() = scene.centre;
    particles.radius() = scene.radius;
    particles.setMassesFromDensity(2.0);
    std::mt19937_64 rng(9);
    std::normal_distribution<double> g(0.0, 1.0);
    for (Index i = 0; i < particles.count(); ++i) {
      for (int k = 0; k < 3; ++k) {
        particles.velocity()(k, i) = g(rng);
        particles.angularVelocity()(k, i) = g(rng);
      }
    }
    if (skin < 0.0) {  // as wide as the box allows: every pair when walled, the nearest quarter or so when periodic
      skin = periodic ? 0.49 * scene.box.length(0) - 2.0 * scene.radius.maxCoeff() : 1e6;
    }
    const std::vector<broadphase::Pair> pairs = test::pairsFrom("brute", scene, skin);
    list.offset.assign(static_cast<std::size_t>(particles.count()) + 1, 0);
    for (const auto& p : pairs) ++list.offset[static_cast<std::size_t>(p.i) + 1];
    for (Index i = 0; i < particles.count(); ++i) list.offset[i + 1] += list.offset[i];
    for (const auto& p : pairs) list.neighbour.push_back(p.j);  // pairs are sorted by (i, j)
    std::vector<std::uint64_t> keys;
    for (const auto& p : pairs) keys.push_back(pairKey(p.i, p.j));
    pairHistory.remap(keys);
  }

  ForceContext context() {
    ForceContext c;
    c.count = particles.count();
    c.position = particles.position().data();
    c.velocity = c.velocityHalf = particles.velocity().data();
    c.radius = particles.radius().data();
    c.inverseMass = particles.inverseMass().data();
    c.force = particles.force().data();
    c.angularVelocity = c.angularVelocityHalf = particles.angularVelocity().data();
    c.inverseInertia = particles.inverseInertia().data();
    c.torque = particles.torque().data();
    c.list = &list;
    c.pairHistory = &pairHistory;
    c.wallHistory = &wallHistory;
    for (int k = 0; k < 3; ++k) {
      c.length[k] = scene.box.length(k);
      c.halfLength[k] = scene.box.periodic(k) ? 0.5 * scene.box.length(k) : std::numeric_limits<double>::infinity();
    }
    c.dt = 1e-4;
    return c;
  }
};

ContactModel model(double friction, NormalModel normal = NormalModel::Linear) {
  ContactParameters p;
  p.normal = normal;
  p.stiffness = 1e5;
  p.restitution = 0.7;
  p.friction = friction;
  p.tangentialDampingRatio = 0.3;
  return ContactModel(p);
}

TEST(ForceLoop, ForcesAndAngularMomentumBalance) {
  for (NormalModel normal : {NormalModel::Linear, NormalModel::Hertz}) {
    Fixture fx(false);  // walled box, but no wall flag: only pair forces, so they must cancel
    const ContactModel m = model(0.5, normal);
    const ForceKernel k = selectForceKernel(m, KernelFlags{});
    ASSERT_TRUE(k.rotation);
    for (int repeat = 0; repeat < 3; ++repeat) k.run(m, fx.context());  // let the springs load
    EXPECT_GT(fx.pairHistory.activeCount(), 100u);
    const Eigen::Vector3d total = fx.particles.force().rowwise().sum();
    const double scale = fx.particles.force().cwiseAbs().sum();
    EXPECT_LT(total.norm(), 1e-13 * scale);
    // Lever arms r - overlap/2 sum to the centre distance: sum of torque + x cross F vanishes.
    Eigen::Vector3d angular = Eigen::Vector3d::Zero();
    for (Index i = 0; i < fx.particles.count(); ++i) {
      const Eigen::Vector3d x = fx.particles.position().col(i);
      angular += fx.particles.torque().col(i) + x.cross(Eigen::Vector3d(fx.particles.force().col(i)));
    }
    EXPECT_LT(angular.norm(), 1e-12 * scale * fx.scene.box.length(0));
  }
}

TEST(ForceLoop, GeneralKernelComputesTheSameForcesWithoutFriction) {
  Fixture a(true), b(true);
  const ContactModel m = model(0.0);
  const ForceKernel lean = selectForceKernel(m, KernelFlags{});
  const ForceKernel general = selectForceKernel(m, KernelFlags{}, true);
  EXPECT_FALSE(lean.rotation);
  EXPECT_EQ(lean.historyWidth, 0);
  EXPECT_TRUE(general.rotation);
  lean.run(m, a.context());
  general.run(m, b.context());
  EXPECT_TRUE(a.particles.force() == b.particles.force()) << "bit-identical forces expected";
  EXPECT_EQ(b.particles.torque().cwiseAbs().maxCoeff(), 0.0);
}

TEST(ForceLoop, SeparatedContactsForgetTheirSpring) {
  Fixture fx(true);
  const ContactModel m = model(0.5);
  const ForceKernel k = selectForceKernel(m, KernelFlags{});
  k.run(m, fx.context());
  const std::size_t active = fx.pairHistory.activeCount();
  EXPECT_GT(active, 0u);
  fx.particles.radius() *= 1e-4;  // every contact opens
  k.run(m, fx.context());
  EXPECT_EQ(fx.pairHistory.activeCount(), 0u);
}

TEST(ContactList, BlocksSplitTheRowsAndListEveryCrossPairOnce) {
  Fixture fx(true);
  for (int blocks : {1, 2, 3, 7}) {
    SCOPED_TRACE(::testing::Message() << blocks << " blocks");
    fx.list.buildBlocks(blocks);
    ASSERT_EQ(fx.list.blockCount(), blocks);
    EXPECT_EQ(fx.list.blockStart.front(), 0);
    EXPECT_EQ(fx.list.blockStart.back(), fx.particles.count());
    auto blockOf = [&](Index i) {
      Index b = 0;
      while (i >= fx.list.blockStart[b + 1]) ++b;
      return b;
    };
    std::vector<Index> expected;  // slots whose j lies in a later block, ascending
    for (Index i = 0; i < fx.particles.count(); ++i) {
      for (Index c = fx.list.offset[i]; c < fx.list.offset[i + 1]; ++c) {
        if (blockOf(fx.list.neighbour[c]) > blockOf(i)) expected.push_back(c);
      }
    }
    EXPECT_EQ(fx.list.crossPair, expected);
    if (blocks > 1) {
      EXPECT_GT(expected.size(), 0u);
    }
    for (Index b = 0; b < blocks; ++b) {
      for (Index q = fx.list.crossStart[b]; q < fx.list.crossStart[b + 1]; ++q)
        EXPECT_EQ(blockOf(fx.list.crossRow[q]), b);
      Index previous = -1;
      for (Index m = fx.list.targetOffset[b]; m < fx.list.targetOffset[b + 1]; ++m) {
        const Index q = fx.list.byTarget[m];
        EXPECT_EQ(blockOf(fx.list.neighbour[fx.list.crossPair[q]]), b);
        EXPECT_GT(q, previous);
        previous = q;
      }
    }
    EXPECT_EQ(static_cast<std::size_t>(fx.list.targetOffset[blocks]), expected.size());
  }
}

/// Calls body(model, kernel) for every normal law, frictionless and frictional, specialised and general.
template <class Body>
void forEveryKernel(Body body) {
  for (NormalModel normal : {NormalModel::Linear, NormalModel::Hertz}) {
    for (double friction : {0.0, 0.5}) {
      for (bool general : {false, true}) {
        SCOPED_TRACE(::testing::Message()
                     << "hertz " << (normal == NormalModel::Hertz) << " mu " << friction << " general " << general);
        const ContactModel m = model(friction, normal);
        body(m, selectForceKernel(m, KernelFlags{}, general));
      }
    }
  }
}

#if POLYDEM_WITH_OPENMP
TEST(ForceLoop, ThreadedLoopIsBitIdenticalToTheSerialOne) {
  // Every law, with and without walls/gravity/damping: same forces, torques and springs for any thread
  // count (the owner-computes loop sums every force in the serial order); 8 blocks on a 400-sphere scene
  // make many cross pairs.
  forEveryKernel([](const ContactModel& m, const ForceKernel& k) {
    Fixture serial(false), threaded(false);
    for (int threads : {2, 3, 8}) {
      threaded.list.buildBlocks(threads);
      std::vector<double> scratch(crossScratchSize(threaded.list.crossCount(), k.rotation));
      std::vector<std::uint8_t> touching(threaded.list.crossCount());
      for (int repeat = 0; repeat < 3; ++repeat) {  // springs load over several calls
        ForceContext a = serial.context(), b = threaded.context();
        for (ForceContext* c : {&a, &b}) {
          c->gravity[2] = -9.81;
          c->viscousRate = 0.3;
        }
        b.threads = threads;
        b.crossScratch = scratch.data();
        b.crossTouching = touching.data();
        k.run(m, a);
        k.run(m, b);
        ASSERT_TRUE(serial.particles.force() == threaded.particles.force()) << threads << " threads";
        if (k.rotation) {
          ASSERT_TRUE(serial.particles.torque() == threaded.particles.torque()) << threads << " threads";
        }
      }
    }
    if (k.historyWidth > 0) {
      EXPECT_GT(serial.pairHistory.activeCount(), 50u);
      for (std::size_t c = 0; c < serial.list.pairCount(); ++c) {
        for (int q = 0; q < 3; ++q) ASSERT_EQ(serial.pairHistory.values(c)[q], threaded.pairHistory.values(c)[q]);
      }
    }
  });
}
#endif

TEST(ForceLoop, LookAheadChangesNoResult) {
  // The prefetching variants of the loop read and write exactly what the plain one does: same forces,
  // torques and springs, serial and (OpenMP builds) threaded, for every law.
  forEveryKernel([](const ContactModel& m, const ForceKernel& k) {
    for (int threads : {1, 3}) {
      if (threads > 1 && !POLYDEM_WITH_OPENMP) continue;
      Fixture plain(true), ahead(true);
      for (Fixture* f : {&plain, &ahead}) f->list.buildBlocks(threads);
      std::vector<double> scratch(crossScratchSize(plain.list.crossCount(), k.rotation));
      std::vector<std::uint8_t> touching(plain.list.crossCount());
      for (LookAhead mode : {LookAhead::Centres, LookAhead::Contacts, LookAhead::Centres}) {
        ForceContext a = plain.context(), b = ahead.context();
        for (ForceContext* c : {&a, &b}) {
          c->gravity[2] = -9.81;
          c->threads = threads;
          c->crossScratch = scratch.data();
          c->crossTouching = touching.data();
        }
        b.lookAhead = mode;
        k.run(m, a);
        k.run(m, b);
        ASSERT_TRUE(plain.particles.force() == ahead.particles.force()) << threads << " threads";
        if (k.rotation) {
          ASSERT_TRUE(plain.particles.torque() == ahead.particles.torque());
        }
      }
      if (k.historyWidth > 0) {
        for (std::size_t c = 0; c < plain.list.pairCount(); ++c) {
          for (int q = 0; q < 3; ++q) ASSERT_EQ(plain.pairHistory.values(c)[q], ahead.pairHistory.values(c)[q]);
        }
      }
    }
  });
}

TEST(ForceLoop, BatchedLoopIsBitIdenticalToTheOnePassLoop) {
  // Laws without rotation or pair history sum the pairs in batches of candidates taken across rows: the
  // contact tests, then the touching pairs' forces, then the sums in the one-pass loop's order. Against
  // the one-pass loop, the forces are the same byte for byte (signs of zero included): serial and threaded
  // (cross pairs), periodic and walled, with a Verlet skin (rows with no candidates between others) and with
  // the widest skin (walled: every pair a candidate, rows of up to 399 candidates, split across batches).
  int batchedKernels = 0;
  forEveryKernel([&](const ContactModel& m, const ForceKernel& k) {
    if (!k.batched()) return;  // the one-pass loop only
    ++batchedKernels;
    for (double skin : {0.1, -1.0}) {
      for (bool periodic : {true, false}) {
        for (int threads : {1, 3}) {
          if (threads > 1 && !POLYDEM_WITH_OPENMP) continue;
          Fixture onePass(periodic, skin), batched(periodic, skin);
          for (Fixture* f : {&onePass, &batched}) f->list.buildBlocks(threads);
          std::vector<double> scratch(crossScratchSize(onePass.list.crossCount(), false));
          std::vector<std::uint8_t> touching(onePass.list.crossCount());
          ForceContext a = onePass.context(), b = batched.context();
          for (ForceContext* x : {&a, &b}) {
            x->gravity[2] = -9.81;
            x->viscousRate = 0.3;
            x->threads = threads;
            x->crossScratch = scratch.data();
            x->crossTouching = touching.data();
          }
          a.batching = Batching::OnePass;
          EXPECT_EQ(b.batching, Batching::Batched);  // the default
          k.run(m, a);
          k.run(m, b);
          const auto bytes = sizeof(double) * static_cast<std::size_t>(onePass.particles.force().size());
          ASSERT_EQ(std::memcmp(onePass.particles.force().data(), batched.particles.force().data(), bytes), 0)
              << k.name << ", skin " << skin << (periodic ? ", periodic, " : ", walled, ") << threads << " threads";
          if (skin < 0.0 && !periodic) {
            ASSERT_EQ(onePass.list.pairCount(), 79800u);  // every pair of 400
          }
        }
      }
    }
  });
  EXPECT_GE(batchedKernels, 2);
}

TEST(ForceLoop, LookAheadOnlyForLargeSystemsAndContactDataOnlyWhenManyCandidatesTouch) {
  for (const bool batched : {false, true}) {
    EXPECT_EQ(chooseLookAhead(kLookAheadMinCount - 1, 1.0, batched), LookAhead::None);
    EXPECT_EQ(chooseLookAhead(kLookAheadMinCount, 0.0, batched), LookAhead::Centres);
    EXPECT_EQ(chooseLookAhead(kLookAheadMinCount, 0.2, batched), LookAhead::Centres);
  }
  EXPECT_EQ(chooseLookAhead(kLookAheadMinCount, 0.25, false), LookAhead::Contacts);
  EXPECT_EQ(chooseLookAhead(10 * kLookAheadMinCount, 0.9, false), LookAhead::Contacts);
  // The batched loop reads the touching pairs' velocities and forces after the batch's contact tests.
  EXPECT_EQ(chooseLookAhead(kLookAheadMinCount, 0.25, true), LookAhead::Centres);
  EXPECT_EQ(chooseLookAhead(10 * kLookAheadMinCount, 0.9, true), LookAhead::Centres);
}

TEST(ForceLoop, MeasureReportsTheLargestOverlap) {
  Fixture fx(true);
  const ContactModel m = model(0.0);
  const ContactStats s = measureContacts(m, fx.context());
  EXPECT_GT(s.contacts, 0u);
  ASSERT_GE(s.maxOverlapI, 0);
  ASSERT_GE(s.maxOverlapJ, 0);
  const Index i = s.maxOverlapI, j = s.maxOverlapJ;
  const double dist = fx.scene.box.minimumImage(fx.particles.position().col(i) - fx.particles.position().col(j)).norm();
  const double ri = fx.particles.radius()[i], rj = fx.particles.radius()[j];
  EXPECT_NEAR(s.maxOverlapRatio, (ri + rj - dist) / std::min(ri, rj), 1e-12);
  EXPECT_GT(s.elasticEnergy, 0.0);
}

}  // namespace
}  // namespace polydem::contact
