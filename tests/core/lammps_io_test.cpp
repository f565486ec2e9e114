#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/io/lammps_data.hpp"
#include "core/io/lammps_dump.hpp"
#include "core/io/particle_io.hpp"

namespace polydem::io {
namespace {

namespace fs = std::filesystem;

class LammpsIo : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("polydem_lammps_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  fs::path dir_;
};

ParticleData makeData(Index n) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ParticleData d;
  d.box = Box(Eigen::Vector3d(2.0, 3.0, 1.5), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  d.position.resize(3, n);
  d.radius.resize(n);
  d.velocity = Eigen::Matrix3Xd(3, n);
  d.angularVelocity = Eigen::Matrix3Xd(3, n);
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      d.position(k, i) = unit(rng) * d.box.length(k);
      (*d.velocity)(k, i) = unit(rng) - 0.5;
      (*d.angularVelocity)(k, i) = 10.0 * (unit(rng) - 0.5);
    }
    d.radius[i] = 0.01 + 0.1 * unit(rng);
    d.id.push_back(5 * i + 2);
  }
  d.time = 0.125;
  d.attributes["step"] = "40";
  return d;
}

bool same(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * std::size_t(a.size())) == 0;
}

TEST_F(LammpsIo, DataRoundTripIsBitExactWithTypesDensitiesAndImages) {
  ParticleData d = makeData(20);
  Eigen::MatrixXd type(1, 20), density(1, 20), image(3, 20);
  for (Index i = 0; i < 20; ++i) {
    type(0, i) = 1 + i % 3;
    density(0, i) = 1000.0 + i;
    for (int k = 0; k < 3; ++k) image(k, i) = (i % 5) - 2 + k;
  }
  d.arrays = {{"type", type}, {"density", density}, {"image", image}};
  writeLammpsData(dir_ / "a.data", d);
  const ParticleData back = readLammpsData(dir_ / "a.data", {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  EXPECT_EQ(back.id, d.id);
  EXPECT_TRUE(same(back.position, d.position));
  EXPECT_TRUE(same(back.radius, d.radius));
  ASSERT_TRUE(back.velocity && back.angularVelocity);
  EXPECT_TRUE(same(*back.velocity, *d.velocity));
  EXPECT_TRUE(same(*back.angularVelocity, *d.angularVelocity));
  ASSERT_EQ(back.arrays.size(), 3u);
  EXPECT_TRUE(same(back.arrays[0].values, type));
  EXPECT_TRUE(same(back.arrays[1].values, density));
  EXPECT_TRUE(same(back.arrays[2].values, image));
}

TEST_F(LammpsIo, DataBoxOffsetIsShiftedToTheOrigin) {
  const fs::path f = write("o.data",
                           "t\n1 atoms\n1 atom types\n-1 1 xlo xhi\n0 1 ylo yhi\n2 3 zlo zhi\n\nAtoms # sphere\n\n"
                           "7 1 0.2 2500 0.5 0.25 2.5\n");
  const ParticleData d = readLammpsData(f);
  EXPECT_EQ(d.box.lengths(), Eigen::Vector3d(2, 1, 1));
  EXPECT_EQ(d.position.col(0), Eigen::Vector3d(1.5, 0.25, 0.5));
  EXPECT_EQ(d.radius[0], 0.1);
  EXPECT_EQ(d.id[0], 6);
  EXPECT_EQ(d.attributes.at("density"), "2500");
  EXPECT_FALSE(d.velocity);
}

TEST_F(LammpsIo, DataErrorsNameFileAndLine) {
  const fs::path f =
      write("bad.data", "t\n1 atoms\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n\nAtoms\n\n1 1 -0.2 1 0.5 0.5 0.5\n");
  try {
    readLammpsData(f);
    FAIL() << "a negative diameter must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.data:9: diameter must be positive"), std::string::npos) << e.what();
  }
}

TEST_F(LammpsIo, DumpRoundTripKeepsFramesArraysAndTime) {
  ParticleData a = makeData(10);
  a.arrays = {{"force", Eigen::MatrixXd::Random(3, 10)}, {"contact_count", Eigen::MatrixXd::Constant(1, 10, 3.0)}};
  ParticleData b = makeData(10);
  b.time = 0.25;
  b.attributes["step"] = "80";
  b.velocity.reset();
  b.angularVelocity.reset();
  const std::vector<ParticleData> frames = {a, b};
  writeLammpsDump(dir_ / "x.dump", frames);
  const std::vector<ParticleData> back = readLammpsDump(dir_ / "x.dump");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].time, 0.125);
  EXPECT_EQ(back[1].attributes.at("step"), "80");
  EXPECT_EQ(back[0].box, a.box);
  EXPECT_EQ(back[0].id, a.id);
  EXPECT_TRUE(same(back[0].position, a.position));
  EXPECT_TRUE(same(back[0].radius, a.radius));
  EXPECT_TRUE(same(*back[0].velocity, *a.velocity));
  EXPECT_TRUE(same(*back[0].angularVelocity, *a.angularVelocity));
  ASSERT_EQ(back[0].arrays.size(), 2u);
  EXPECT_EQ(back[0].arrays[0].name, "contact_count");
  EXPECT_TRUE(same(back[0].arrays[0].values, a.arrays[1].values));
  EXPECT_EQ(back[0].arrays[1].name, "force");
  EXPECT_TRUE(same(back[0].arrays[1].values, a.arrays[0].values));
  EXPECT_FALSE(back[1].velocity);
  EXPECT_TRUE(back[1].arrays.empty());
}

TEST_F(LammpsIo, ParticleFilesDispatchOnLammpsExtensions) {
  const ParticleData d = makeData(4);
  writeParticles(dir_ / "p.data", d);
  writeParticles(dir_ / "p.dump", d);
  EXPECT_TRUE(same(readParticles(dir_ / "p.data", {Boundary::Periodic, Boundary::Periodic, Boundary::Wall}).position,
                   d.position));
  EXPECT_TRUE(same(readParticles(dir_ / "p.dump").position, d.position));
  const std::vector<ParticleData> two = {d, d};
  writeLammpsDump(dir_ / "two.dump", two);
  EXPECT_THROW(readParticles(dir_ / "two.dump"), InputError);
}

}  // namespace
}  // namespace polydem::io
