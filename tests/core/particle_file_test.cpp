#include "core/io/particle_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/errors.hpp"

namespace polydem::io {
namespace {

namespace fs = std::filesystem;

/// A fresh directory per test, removed afterwards.
class TextFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("polydem_io_") + info->test_suite_name() + "_" + info->name() + "_" +
                       std::to_string(::getpid());
    std::replace(name.begin(), name.end(), '/', '_');  // parameterised test names contain '/'
    dir_ = fs::path(::testing::TempDir()) / name;
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& content) const {
    const fs::path file = dir_ / name;
    std::ofstream(file, std::ios::binary) << content;
    return file;
  }

  fs::path dir_;
};

ParticleData randomData(Index n, bool withVelocity, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ParticleData data;
  data.box = Box(Eigen::Vector3d(10.0, 7.25, 1.0 / 3.0), {Boundary::Periodic, Boundary::Wall, Boundary::Periodic});
  data.position.resize(3, n);
  data.radius.resize(n);
  data.id.resize(std::size_t(n));
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) data.position(k, i) = unit(rng) * data.box.length(k);
    data.radius[i] = 0.01 + 0.1 * unit(rng);
    data.id[std::size_t(i)] = i;
  }
  if (withVelocity) {
    data.velocity = Eigen::Matrix3Xd(3, n);
    for (Index i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) (*data.velocity)(k, i) = (unit(rng) - 0.5) * 1e3;
    }
  }
  return data;
}

/// Bitwise equality, so -0.0 vs 0.0 or a last-bit difference fails.
bool bitEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  return std::equal(a.data(), a.data() + a.size(), b.data(), [](double x, double y) {
    return std::memcmp(&x, &y, sizeof(double)) == 0;
  });
}

TEST_F(TextFileTest, RoundTripIsBitExactWithVelocities) {
  ParticleData data = randomData(200, true, 1);
  // Awkward values: shortest decimal forms longer than 15 digits, tiny and huge magnitudes.
  data.position(0, 0) = 0.1;
  data.position(1, 0) = 0.0;
  data.position(1, 1) = data.box.length(1);  // on the wall: allowed
  data.position(0, 2) = std::nextafter(data.box.length(0), 0.0);
  data.radius[0] = 1e-300;
  data.radius[1] = 4.9406564584124654e-324;  // smallest subnormal
  (*data.velocity)(2, 0) = -1.7976931348623157e308;
  const fs::path file = dir_ / "round.txt";
  writeText(file, data);
  const ParticleData back = readText(file);

  EXPECT_EQ(back.box, data.box);  // boundaries come from the comment, not the default
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_TRUE(bitEqual(back.radius, data.radius));
  ASSERT_TRUE(back.velocity.has_value());
  EXPECT_TRUE(bitEqual(*back.velocity, *data.velocity));
  EXPECT_EQ(back.id, data.id);
  EXPECT_EQ(back.count(), 200);
}

TEST_F(TextFileTest, RoundTripWithoutVelocities) {
  const ParticleData data = randomData(50, false, 2);
  const fs::path file = dir_ / "novel.dat";
  writeText(file, data);
  const ParticleData back = readText(file);
  EXPECT_FALSE(back.velocity.has_value());
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_TRUE(bitEqual(back.radius, data.radius));
}

TEST_F(TextFileTest, EmptyConfigurationRoundTrips) {
  ParticleData data;
  data.box = Box::cubic(2.0, Boundary::Wall);
  writeText(dir_ / "empty.txt", data);
  const ParticleData back = readText(dir_ / "empty.txt");
  EXPECT_EQ(back.count(), 0);
  EXPECT_EQ(back.position.cols(), 0);
  EXPECT_TRUE(back.id.empty());
  EXPECT_EQ(back.box, data.box);
}

TEST_F(TextFileTest, IdsAreLineOrder) {
  ParticleData data = randomData(5, false, 3);
  data.id = {40, 30, 20, 10, 0};  // text files do not store ids
  writeText(dir_ / "ids.txt", data);
  EXPECT_EQ(readText(dir_ / "ids.txt").id, (std::vector<Index>{0, 1, 2, 3, 4}));
}

TEST_F(TextFileTest, CommentsBlankLinesAndCrLfAreAccepted) {
  const fs::path file = write("comments.txt",
                              "# a scene\n"
                              "\n"
                              "   # indented comment\r\n"
                              "2 4 5 6   # N Lx Ly Lz\r\n"
                              "1 2 3 0.5\n"
                              "\t\n"
                              "# between particles\n"
                              "+1.5 2.5e0 3.5 .25 # trailing\n"
                              "# the end\n");
  const ParticleData data = readText(file);
  ASSERT_EQ(data.count(), 2);
  EXPECT_EQ(data.box.lengths(), Eigen::Vector3d(4, 5, 6));
  EXPECT_TRUE(data.box.fullyPeriodic());
  EXPECT_EQ(data.position.col(1), Eigen::Vector3d(1.5, 2.5, 3.5));
  EXPECT_EQ(data.radius[1], 0.25);
  EXPECT_FALSE(data.velocity.has_value());
  EXPECT_EQ(data.time, 0.0);
  EXPECT_TRUE(data.attributes.empty());
}

TEST_F(TextFileTest, BoundariesCommentOverridesDefault) {
  const fs::path file = write("walls.txt", "#boundaries:  wall periodic   wall\n1 1 1 1\n0.5 0.5 0.5 0.1\n");
  const std::array<Boundary, 3> allPeriodic = kAllPeriodic;
  const ParticleData data = readText(file, allPeriodic);
  EXPECT_EQ(data.box.boundary(0), Boundary::Wall);
  EXPECT_EQ(data.box.boundary(1), Boundary::Periodic);
  EXPECT_EQ(data.box.boundary(2), Boundary::Wall);
}

TEST_F(TextFileTest, DefaultBoundariesApplyWithoutComment) {
  const fs::path file = write("plain.txt", "# boundaries are described in the docs\n1 1 1 1\n0.5 0.5 0.5 0.1\n");
  EXPECT_TRUE(readText(file).box.fullyPeriodic());
  const ParticleData walled = readText(file, {Boundary::Wall, Boundary::Wall, Boundary::Periodic});
  EXPECT_EQ(walled.box.boundary(0), Boundary::Wall);
  EXPECT_EQ(walled.box.boundary(1), Boundary::Wall);
  EXPECT_EQ(walled.box.boundary(2), Boundary::Periodic);
}

TEST_F(TextFileTest, PeriodicCoordinatesAreWrapped) {
  const fs::path file = write("wrap.txt",
                              "# boundaries: periodic periodic wall\n"
                              "2 10 10 10\n"
                              "-0.5 12 10 0.1\n"
                              "10 20 0 0.1\n");
  const ParticleData data = readText(file);
  EXPECT_EQ(data.position.col(0), Eigen::Vector3d(9.5, 2.0, 10.0));  // z = L on a wall is inside
  EXPECT_EQ(data.position.col(1), Eigen::Vector3d(0.0, 0.0, 0.0));
}

TEST_F(TextFileTest, VelocitiesAreRead) {
  const fs::path file = write("vel.txt", "2 1 1 1\n0.1 0.2 0.3 0.1 1 2 3\n0.4 0.5 0.6 0.1 -1 -2 -3\n");
  const ParticleData data = readText(file);
  ASSERT_TRUE(data.velocity.has_value());
  EXPECT_EQ(data.velocity->col(1), Eigen::Vector3d(-1, -2, -3));
}

TEST_F(TextFileTest, ReadAndWriteParticlesDispatchOnExtension) {
  const ParticleData data = randomData(10, true, 4);
  writeParticles(dir_ / "x.particles", data);
  const ParticleData back = readParticles(dir_ / "x.particles");
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_TRUE(isHdf5Path("a/b.h5"));
  EXPECT_TRUE(isHdf5Path("b.HDF5"));
  EXPECT_FALSE(isHdf5Path("b.h5.txt"));
  EXPECT_FALSE(isHdf5Path("h5"));
}

TEST_F(TextFileTest, WriteRejectsInconsistentSizes) {
  ParticleData data = randomData(3, true, 5);
  data.id.pop_back();
  EXPECT_THROW(writeText(dir_ / "bad.txt", data), ConfigError);
  data = randomData(3, true, 5);
  data.velocity->resize(3, 2);
  EXPECT_THROW(writeText(dir_ / "bad.txt", data), ConfigError);
  data = randomData(3, false, 5);
  data.position.resize(3, 4);
  EXPECT_THROW(writeText(dir_ / "bad.txt", data), ConfigError);
}

TEST_F(TextFileTest, WriteIntoMissingDirectoryNamesFile) {
  const fs::path file = dir_ / "no" / "such" / "dir.txt";
  try {
    writeText(file, randomData(1, false, 6));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

TEST_F(TextFileTest, MissingFileNamesFile) {
  const fs::path file = dir_ / "absent.txt";
  try {
    readText(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------------
// Every malformed file: InputError "FILE:LINE: problem".

struct BadFile {
  std::string name;     // test name
  std::string content;  // file content
  int line;             // expected line in the message
  std::vector<std::string> problem;  // substrings the message must contain
};

void PrintTo(const BadFile& c, std::ostream* os) { *os << c.name; }

class TextFileErrors : public TextFileTest, public ::testing::WithParamInterface<BadFile> {};

TEST_P(TextFileErrors, ThrowInputErrorNamingFileLineAndProblem) {
  const BadFile& c = GetParam();
  const fs::path file = write(c.name + ".txt", c.content);
  try {
    readText(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(file.string() + ":" + std::to_string(c.line) + ": ", 0), 0u) << message;
    for (const std::string& part : c.problem) EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

const BadFile kBadFiles[] = {
    {"EmptyFile", "", 1, {"no header"}},
    {"OnlyComments", "# nothing\n\n# here\n", 3, {"no header"}},
    {"HeaderThreeColumns", "3 1 1\n", 1, {"header", "expected 4 columns", "got 3"}},
    {"HeaderFiveColumns", "# c\n3 1 1 1 1\n", 2, {"header", "expected 4 columns", "got 5"}},
    {"NegativeCount", "-1 1 1 1\n", 1, {"column 1 (N)", "non-negative integer", "-1"}},
    {"FractionalCount", "2.5 1 1 1\n", 1, {"column 1 (N)", "non-negative integer", "'2.5'"}},
    {"ExponentCount", "1e3 1 1 1\n", 1, {"column 1 (N)", "'1e3'"}},
    {"WordCount", "many 1 1 1\n", 1, {"column 1 (N)", "'many'"}},
    {"HugeCount", "99999999999 1 1 1\n", 1, {"column 1 (N)", "exceeds the maximum"}},
    {"ZeroBoxLength", "1 1 0 1\n", 1, {"column 3 (Ly)", "positive", "'0'"}},
    {"NegativeBoxLength", "1 -2 1 1\n", 1, {"column 2 (Lx)", "positive", "'-2'"}},
    {"NanBoxLength", "1 1 1 nan\n", 1, {"column 4 (Lz)", "positive and finite", "'nan'"}},
    {"UnparsableBoxLength", "1 1 1 1,5\n", 1, {"column 4 (Lz)", "cannot parse '1,5'"}},
    {"FiveColumns", "1 1 1 1\n0.5 0.5 0.5 0.1 7\n", 2, {"expected 4 columns (x y z r) or 7", "got 5"}},
    {"ThreeColumns", "1 1 1 1\n0.5 0.5 0.5\n", 2, {"expected 4 columns (x y z r) or 7", "got 3"}},
    {"MixedColumns", "2 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 0.1 0 0 0\n", 3,
     {"expected 4 columns (as on line 2), got 7"}},
    {"MixedColumnsVelocityFirst", "2 1 1 1\n\n0.5 0.5 0.5 0.1 0 0 0\n0.5 0.5 0.5 0.1\n", 4,
     {"expected 7 columns (as on line 3), got 4"}},
    {"UnparsableY", "1 1 1 1\n0.5 0.5x 0.5 0.1\n", 2, {"column 2 (y)", "cannot parse '0.5x'"}},
    {"UnparsableVelocity", "1 1 1 1\n0.5 0.5 0.5 0.1 0 0 fast\n", 2, {"column 7 (vz)", "cannot parse 'fast'"}},
    {"EmptyNumberAfterSign", "1 1 1 1\n+ 0.5 0.5 0.1\n", 2, {"column 1 (x)", "cannot parse '+'"}},
    {"NanPosition", "1 1 1 1\n0.5 0.5 nan 0.1\n", 2, {"column 3 (z)", "not finite", "'nan'"}},
    {"InfRadius", "1 1 1 1\n0.5 0.5 0.5 inf\n", 2, {"column 4 (r)", "not finite", "'inf'"}},
    {"OverflowVelocity", "1 1 1 1\n0.5 0.5 0.5 0.1 1e999 0 0\n", 2, {"column 5 (vx)", "'1e999' is out of the range"}},
    {"UnderflowPosition", "1 1 1 1\n0.5 1e-400 0.5 0.1\n", 2, {"column 2 (y)", "'1e-400' is out of the range"}},
    {"NanVelocity", "1 1 1 1\n0.5 0.5 0.5 0.1 0 -nan 0\n", 2, {"column 6 (vy)", "not finite"}},
    {"ZeroRadius", "1 1 1 1\n0.5 0.5 0.5 0\n", 2, {"column 4 (r)", "radius must be positive", "'0'"}},
    {"NegativeRadius", "2 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 -0.1\n", 3,
     {"column 4 (r)", "radius must be positive", "'-0.1'"}},
    {"OutsideWallAbove", "# boundaries: wall wall wall\n1 10 10 10\n10.5 5 5 0.1\n", 3,
     {"column 1 (x)", "outside the walled box [0, 10] along x", "'10.5'"}},
    {"OutsideWallBelow", "# boundaries: periodic periodic wall\n1 10 10 4\n50 -5 -0.001 0.1\n", 3,
     {"column 3 (z)", "outside the walled box [0, 4] along z"}},
    {"Truncated", "# three\n3 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 0.1\n# trailing comment\n", 5,
     {"truncated", "expected 3 particles", "found 2", "header on line 2"}},
    {"TruncatedNoParticles", "2 1 1 1\n", 1, {"expected 2 particles", "found 0"}},
    {"ExtraLine", "1 1 1 1\n0.5 0.5 0.5 0.1\n# ok so far\n0.5 0.5 0.5 0.1\n", 4,
     {"extra data", "declares N = 1, all already read"}},
    {"ExtraLineAfterEmpty", "0 1 1 1\n1\n", 2, {"extra data", "declares N = 0"}},
    {"BoundariesWrongCount", "# boundaries: wall wall\n1 1 1 1\n", 1, {"boundaries", "expected 3 words", "got 2"}},
    {"BoundariesUnknownWord", "# boundaries: wall walls periodic\n1 1 1 1\n", 1,
     {"boundaries", "unknown boundary 'walls' along y"}},
    {"BoundariesTwice", "# boundaries: wall wall wall\n# boundaries: wall wall wall\n1 1 1 1\n", 2,
     {"boundaries given twice (first on line 1)"}},
    {"BoundariesAfterHeader", "1 1 1 1\n# boundaries: wall wall wall\n0.5 0.5 0.5 0.1\n", 2,
     {"must come before the header line (line 1)"}},
};

INSTANTIATE_TEST_SUITE_P(Malformed, TextFileErrors, ::testing::ValuesIn(kBadFiles),
                         [](const ::testing::TestParamInfo<BadFile>& info) { return info.param.name; });

}  // namespace
}  // namespace polydem::io
