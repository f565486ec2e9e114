#include "core/io/particle_file.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "core/errors.hpp"

namespace polydem::io {
namespace {

namespace fs = std::filesystem;

/// A fresh directory per test, removed afterwards.
class TextFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name =
        std::string("polydem_io_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(::getpid());
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
  return std::equal(a.data(), a.data() + a.size(), b.data(),
                    [](double x, double y) { return std::memcmp(&x, &y, sizeof(double)) == 0; });
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

// Issue 15 changed this: ids that are not 0..N-1 are now stored (an `id` column), not replaced by line order.
TEST_F(TextFileTest, IdsThatAreNotLineOrderAreStored) {
  ParticleData data = randomData(5, true, 3);
  data.id = {40, 30, 20, 10, 0};
  writeText(dir_ / "ids.txt", data);
  const ParticleData back = readText(dir_ / "ids.txt");
  EXPECT_EQ(back.id, data.id);
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_TRUE(bitEqual(*back.velocity, *data.velocity));
}

TEST_F(TextFileTest, LineOrderIdsWriteNoIdColumn) {
  writeText(dir_ / "plain.txt", randomData(3, false, 3));
  const std::string text = [&] {
    std::ifstream in(dir_ / "plain.txt");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(text.find("# columns: x y z r\n"), std::string::npos) << text;
  EXPECT_EQ(readText(dir_ / "plain.txt").id, (std::vector<Index>{0, 1, 2}));
}

TEST_F(TextFileTest, IdsWithoutColumnsLineAreLineOrder) {
  const fs::path file = write("noids.txt", "2 1 1 1\n0.5 0.5 0.5 0.1\n0.2 0.2 0.2 0.1\n");
  EXPECT_EQ(readText(file).id, (std::vector<Index>{0, 1}));
}

TEST_F(TextFileTest, WriteRejectsDuplicateOrNegativeIds) {
  ParticleData data = randomData(3, false, 3);
  data.id = {5, 7, 5};
  EXPECT_THROW(writeText(dir_ / "dup.txt", data), ConfigError);
  data.id = {5, -1, 2};
  EXPECT_THROW(writeText(dir_ / "neg.txt", data), ConfigError);
  EXPECT_FALSE(fs::exists(dir_ / "dup.txt"));
}

// Issue 15: time, attributes and boundaries travel with the data in text files too.
TEST_F(TextFileTest, MetadataRoundTrips) {
  ParticleData data = randomData(4, false, 7);
  data.time = 12.5000000000000018;
  data.attributes = {
      {"reduced_pressure", "1.0000000000004e12"},
      {"key with spaces", "value with spaces"},
      {"a=b", "c=d # not a comment"},
      {"quote\"and\\backslash", "line1\nline2\r\ttab"},
      {"control", std::string("nul\0byte\x01\x7f", 10)},
      {"empty", ""},
      {"padded", "  leading and trailing  "},
      {"#hash", "#"},
      {"utf8", "\xc3\xa9t\xc3\xa9 \xcf\x86"},
      {"\"", "\""},
  };
  writeText(dir_ / "meta.txt", data);
  const ParticleData back = readText(dir_ / "meta.txt", {Boundary::Wall, Boundary::Wall, Boundary::Wall});
  EXPECT_EQ(back.attributes, data.attributes);
  EXPECT_EQ(back.time, data.time);
  EXPECT_EQ(back.box, data.box);
  EXPECT_TRUE(bitEqual(back.position, data.position));
}

TEST_F(TextFileTest, HandWrittenMetadataIsParsed) {
  const fs::path file = write("hand.txt",
                              "# written by hand: comments with colons are free text\n"
                              "# time:   -3.25\r\n"
                              "# attribute: pressure = 1e12\n"
                              "#attribute:   note   =   two words  \n"
                              "# attribute: \"k k\" = \"v\\x41\\\"\"\n"
                              "# boundaries are described below (free text: no colon after the word)\n"
                              "1 1 1 1\n0.5 0.5 0.5 0.1\n");
  const ParticleData back = readText(file);
  EXPECT_EQ(back.time, -3.25);
  EXPECT_EQ(back.attributes.at("pressure"), "1e12");
  EXPECT_EQ(back.attributes.at("note"), "two words");
  EXPECT_EQ(back.attributes.at("k k"), "vA\"");
  EXPECT_EQ(back.attributes.size(), 3u);
}

// Issue 15: angular velocities are columns wx wy wz after vx vy vz (10 columns).
TEST_F(TextFileTest, AngularVelocitiesRoundTrip) {
  ParticleData data = randomData(30, true, 8);
  data.angularVelocity = Eigen::Matrix3Xd::Random(3, 30) * 1e4;
  (*data.angularVelocity)(0, 0) = -0.0;
  writeText(dir_ / "spin.txt", data);
  const ParticleData back = readText(dir_ / "spin.txt");
  ASSERT_TRUE(back.angularVelocity.has_value());
  EXPECT_TRUE(bitEqual(*back.angularVelocity, *data.angularVelocity));
  EXPECT_TRUE(bitEqual(*back.velocity, *data.velocity));
  // Ten columns without a `# columns:` line are read the same way.
  const fs::path bare = write("bare10.txt", "1 1 1 1\n0.5 0.5 0.5 0.1 1 2 3 4 5 6\n");
  const ParticleData b = readText(bare);
  ASSERT_TRUE(b.angularVelocity.has_value());
  EXPECT_EQ(b.angularVelocity->col(0), Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(b.velocity->col(0), Eigen::Vector3d(1, 2, 3));
}

TEST_F(TextFileTest, ArraysRoundTripAsExtraColumns) {
  ParticleData data = randomData(20, true, 9);
  data.arrays.push_back({"force", Eigen::MatrixXd::Random(3, 20) * 1e-3});
  data.arrays.push_back({"rattler", Eigen::MatrixXd::Constant(1, 20, 1.0)});
  data.arrays.push_back({"max_x", Eigen::MatrixXd::Random(1, 20)});  // a scalar whose name ends in _x
  data.arrays[0].values(1, 3) = -0.0;
  writeText(dir_ / "arrays.txt", data);
  std::ifstream in(dir_ / "arrays.txt");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("# columns: x y z r vx vy vz force_x force_y force_z rattler max_x\n"), std::string::npos)
      << text.str();
  const ParticleData back = readText(dir_ / "arrays.txt");
  ASSERT_EQ(back.arrays.size(), 3u);
  for (std::size_t a = 0; a < 3; ++a) {
    EXPECT_EQ(back.arrays[a].name, data.arrays[a].name);
    EXPECT_TRUE(bitEqual(back.arrays[a].values, data.arrays[a].values)) << data.arrays[a].name;
  }
  EXPECT_TRUE(bitEqual(*back.velocity, *data.velocity));
  // A name the reader would take for a built-in column is refused by the writer.
  data.arrays = {{"vx", Eigen::MatrixXd::Zero(1, 20)}};
  EXPECT_THROW(writeText(dir_ / "bad.txt", data), ConfigError);
}

TEST_F(TextFileTest, AngularVelocitiesWithoutVelocitiesRoundTrip) {
  ParticleData data = randomData(3, false, 9);
  data.angularVelocity = Eigen::Matrix3Xd::Constant(3, 3, 2.5);
  writeText(dir_ / "w.txt", data);
  const ParticleData back = readText(dir_ / "w.txt");
  EXPECT_FALSE(back.velocity.has_value());
  ASSERT_TRUE(back.angularVelocity.has_value());
  EXPECT_TRUE(bitEqual(*back.angularVelocity, *data.angularVelocity));
}

TEST_F(TextFileTest, OneParticleRoundTrips) {
  ParticleData data = randomData(1, true, 10);
  data.angularVelocity = Eigen::Matrix3Xd::Constant(3, 1, -1.0);
  data.id = {7};
  writeText(dir_ / "one.txt", data);
  const ParticleData back = readText(dir_ / "one.txt");
  EXPECT_EQ(back.count(), 1);
  EXPECT_EQ(back.id, data.id);
  EXPECT_TRUE(bitEqual(*back.angularVelocity, *data.angularVelocity));
}

TEST_F(TextFileTest, HeaderOnlyFileIsEmptyConfiguration) {
  const ParticleData back = readText(write("zero.txt", "0 2 3 4\n"));
  EXPECT_EQ(back.count(), 0);
  EXPECT_EQ(back.box.lengths(), Eigen::Vector3d(2, 3, 4));
}

/// The names in `dir`, so a test can check that no temporary was left behind.
std::vector<std::string> listDirectory(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// Limits the size of files this process may write (RLIMIT_FSIZE, SIGXFSZ ignored) for its lifetime, so
/// a write fails part way through as on a full disk.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &saved_);
    previous_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, previous_);
  }

 private:
  rlimit saved_{};
  void (*previous_)(int) = nullptr;
};

// Issue 15: a write that fails part way leaves the previous file intact and no temporary behind.
TEST_F(TextFileTest, FailedWriteKeepsOldFileAndLeavesNoTemporary) {
  const fs::path file = dir_ / "state.txt";
  writeText(file, randomData(3, false, 11));
  const ParticleData old = readText(file);
  const ParticleData big = randomData(20000, true, 12);  // about 2 MB: several buffered writes
  {
    const FileSizeLimit limit(100000);
    EXPECT_THROW(writeText(file, big), InputError);
  }
  const ParticleData back = readText(file);
  EXPECT_EQ(back.count(), 3);
  EXPECT_TRUE(bitEqual(back.position, old.position));
  EXPECT_EQ(listDirectory(dir_), std::vector<std::string>{"state.txt"});
}

TEST_F(TextFileTest, WriteIntoVanishedDirectoryFailsCleanly) {
  const fs::path sub = dir_ / "gone";
  fs::create_directories(sub);
  fs::remove(sub);
  EXPECT_THROW(writeText(sub / "x.txt", randomData(2, false, 13)), InputError);
  EXPECT_TRUE(listDirectory(dir_).empty());
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
  std::string name;                  // test name
  std::string content;               // file content
  int line;                          // expected line in the message
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
    {"FiveColumns", "1 1 1 1\n0.5 0.5 0.5 0.1 7\n", 2, {"expected 4 columns (x y z r), 7", "or 10", "got 5"}},
    {"ThreeColumns", "1 1 1 1\n0.5 0.5 0.5\n", 2, {"expected 4 columns (x y z r), 7", "got 3"}},
    {"MixedColumns",
     "2 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 0.1 0 0 0\n",
     3,
     {"expected 4 columns (as on line 2), got 7"}},
    {"MixedColumnsVelocityFirst",
     "2 1 1 1\n\n0.5 0.5 0.5 0.1 0 0 0\n0.5 0.5 0.5 0.1\n",
     4,
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
    {"NegativeRadius",
     "2 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 -0.1\n",
     3,
     {"column 4 (r)", "radius must be positive", "'-0.1'"}},
    {"OutsideWallAbove",
     "# boundaries: wall wall wall\n1 10 10 10\n10.5 5 5 0.1\n",
     3,
     {"column 1 (x)", "outside the walled box [0, 10] along x", "'10.5'"}},
    {"OutsideWallBelow",
     "# boundaries: periodic periodic wall\n1 10 10 4\n50 -5 -0.001 0.1\n",
     3,
     {"column 3 (z)", "outside the walled box [0, 4] along z"}},
    {"Truncated",
     "# three\n3 1 1 1\n0.5 0.5 0.5 0.1\n0.5 0.5 0.5 0.1\n# trailing comment\n",
     5,
     {"truncated", "expected 3 particles", "found 2", "header on line 2"}},
    {"TruncatedNoParticles", "2 1 1 1\n", 1, {"expected 2 particles", "found 0"}},
    {"ExtraLine",
     "1 1 1 1\n0.5 0.5 0.5 0.1\n# ok so far\n0.5 0.5 0.5 0.1\n",
     4,
     {"extra data", "declares N = 1, all already read"}},
    {"ExtraLineAfterEmpty", "0 1 1 1\n1\n", 2, {"extra data", "declares N = 0"}},
    {"BoundariesWrongCount", "# boundaries: wall wall\n1 1 1 1\n", 1, {"boundaries", "expected 3 words", "got 2"}},
    {"BoundariesUnknownWord",
     "# boundaries: wall walls periodic\n1 1 1 1\n",
     1,
     {"boundaries", "unknown boundary 'walls' along y"}},
    {"TimeTwice", "# time: 1\n# time: 2\n1 1 1 1\n0.5 0.5 0.5 0.1\n", 2, {"time given twice (first on line 1)"}},
    {"TimeNotANumber", "# time: soon\n0 1 1 1\n", 1, {"time comment", "finite number", "'soon'"}},
    {"TimeNan", "# time: nan\n0 1 1 1\n", 1, {"time comment", "'nan'"}},
    {"TimeAfterHeader", "0 1 1 1\n# time: 1\n", 2, {"time comment must come before the header line (line 1)"}},
    {"AttributeNoEquals", "# attribute: pressure 1e12\n0 1 1 1\n", 1, {"no '=' after the key 'pressure'"}},
    {"AttributeNoKey", "# attribute: = 1\n0 1 1 1\n", 1, {"the key is missing"}},
    {"AttributeEmptyQuotedKey", "# attribute: \"\" = 1\n0 1 1 1\n", 1, {"key must not be empty"}},
    {"AttributeUnclosedQuote", "# attribute: k = \"open\n0 1 1 1\n", 1, {"value: missing closing"}},
    {"AttributeBadEscape", "# attribute: k = \"a\\qb\"\n0 1 1 1\n", 1, {"unknown escape '\\q'"}},
    {"AttributeBadHex", "# attribute: k = \"\\x4\"\n0 1 1 1\n", 1, {"\\x needs two hex digits"}},
    {"AttributeTextAfterQuote", "# attribute: k = \"v\" w\n0 1 1 1\n", 1, {"text 'w' after the closing quote"}},
    {"AttributeQuoteInBareKey", "# attribute: a\"b = 1\n0 1 1 1\n", 1, {"quote the whole key"}},
    {"AttributeTwice", "# attribute: k = 1\n# attribute: k = 2\n0 1 1 1\n", 2, {"attribute 'k' given twice"}},
    {"ColumnsUnknown", "# columns: x y z radius\n0 1 1 1\n", 1, {"columns comment", "expected [id] x y z r"}},
    {"ColumnsOutOfOrder", "# columns: x y z r wx wy wz vx vy vz\n0 1 1 1\n", 1, {"columns comment", "'vx' at word 8"}},
    {"ColumnsPartial", "# columns: x y z r vx vy\n0 1 1 1\n", 1, {"columns comment", "the end at word 7"}},
    {"ArrayColumnBadName", "# columns: x y z r bad-name\n0 1 1 1\n", 1, {"columns comment", "'bad-name' at word 5"}},
    {"ArrayColumnBuiltinName", "# columns: x y z r radius\n0 1 1 1\n", 1, {"columns comment", "'radius' at word 5"}},
    {"ArrayColumnTwice", "# columns: x y z r rattler rattler\n0 1 1 1\n", 1, {"array 'rattler' appears twice"}},
    {"ArrayValueNotFinite",
     "# columns: x y z r size_class\n1 1 1 1\n0.5 0.5 0.5 0.1 nan\n",
     3,
     {"column 5 (size_class): expected a finite number, got 'nan'"}},
    {"ArrayValueMissing",
     "# columns: x y z r force_x force_y force_z\n1 1 1 1\n0.5 0.5 0.5 0.1 1 2\n",
     3,
     {"expected 7 columns (as declared on line 1), got 6"}},
    {"ColumnsCountMismatch",
     "# columns: id x y z r\n1 1 1 1\n0.5 0.5 0.5 0.1\n",
     3,
     {"expected 5 columns (as declared on line 1), got 4"}},
    {"IdNotInteger", "# columns: id x y z r\n1 1 1 1\n1.5 0.5 0.5 0.5 0.1\n", 3, {"column 1 (id)", "'1.5'"}},
    {"IdNegative", "# columns: id x y z r\n1 1 1 1\n-1 0.5 0.5 0.5 0.1\n", 3, {"column 1 (id)", "'-1'"}},
    {"IdTwice",
     "# columns: id x y z r\n2 1 1 1\n4 0.5 0.5 0.5 0.1\n4 0.2 0.2 0.2 0.1\n",
     4,
     {"id 4 appears twice (also on line 3)"}},
    {"IdColumnRadiusNamed",
     "# columns: id x y z r\n1 1 1 1\n3 0.5 0.5 0.5 -1\n",
     3,
     {"column 5 (r): radius must be positive"}},
    {"ElevenColumnsWithoutDeclaration", "1 1 1 1\n0 1 1 1 1 0 0 0 0 0 0\n", 2, {"got 11"}},
    {"BoundariesTwice",
     "# boundaries: wall wall wall\n# boundaries: wall wall wall\n1 1 1 1\n",
     2,
     {"boundaries given twice (first on line 1)"}},
    {"BoundariesAfterHeader",
     "1 1 1 1\n# boundaries: wall wall wall\n0.5 0.5 0.5 0.1\n",
     2,
     {"must come before the header line (line 1)"}},
};

INSTANTIATE_TEST_SUITE_P(Malformed, TextFileErrors, ::testing::ValuesIn(kBadFiles),
                         [](const ::testing::TestParamInfo<BadFile>& info) { return info.param.name; });

}  // namespace
}  // namespace polydem::io
