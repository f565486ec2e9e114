#include "core/io/hdf5_snapshot.hpp"

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
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/io/particle_file.hpp"  // readParticles, writeText: the snapshot beside the other formats
#include "polydem/config.hpp"

#if POLYDEM_WITH_HDF5
#include <hdf5.h>
#endif

namespace polydem::io {
namespace {

namespace fs = std::filesystem;

class SnapshotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name =
        std::string("polydem_h5_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(::getpid());
    std::replace(name.begin(), name.end(), '/', '_');
    dir_ = fs::path(::testing::TempDir()) / name;
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

ParticleData makeData(Index n, bool withVelocity, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ParticleData data;
  data.box = Box(Eigen::Vector3d(10.0, 7.25, 0.1), {Boundary::Wall, Boundary::Periodic, Boundary::Wall});
  data.position.resize(3, n);
  data.radius.resize(n);
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) data.position(k, i) = unit(rng) * data.box.length(k);
    data.radius[i] = 0.001 + 0.01 * unit(rng);
    data.id.push_back(3 * (n - i));  // not 0..N-1: ids must survive as stored
  }
  if (withVelocity) {
    data.velocity = Eigen::Matrix3Xd(3, n);
    for (Index i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) (*data.velocity)(k, i) = unit(rng) - 0.5;
    }
  }
  data.time = 1.0 / 3.0;
  return data;
}

[[maybe_unused]] bool bitEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  return std::memcmp(a.data(), b.data(), sizeof(double) * std::size_t(a.size())) == 0;
}

[[maybe_unused]] std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

#if !POLYDEM_WITH_HDF5

TEST_F(SnapshotTest, WithoutHdf5BothDirectionsThrowConfigError) {
  EXPECT_THROW(writeSnapshot(dir_ / "snap.h5", makeData(3, false, 1)), ConfigError);
  EXPECT_THROW(readSnapshot(dir_ / "snap.h5"), ConfigError);
}

#else

TEST_F(SnapshotTest, RoundTripIsBitExact) {
  ParticleData data = makeData(300, true, 1);
  data.position(0, 0) = 0.1;
  data.position(1, 1) = std::nextafter(data.box.length(1), 0.0);
  data.radius[2] = 4.9406564584124654e-324;
  data.attributes = {
      {"packing", "0.64"}, {"law", "hertz <mindlin> & \"friends\""}, {"empty", ""}, {"unicode", "\xce\xbc = 0.5"}};
  const fs::path file = dir_ / "snap.h5";
  writeSnapshot(file, data);
  const ParticleData back = readSnapshot(file);

  EXPECT_EQ(back.box, data.box);
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_TRUE(bitEqual(back.radius, data.radius));
  ASSERT_TRUE(back.velocity.has_value());
  EXPECT_TRUE(bitEqual(*back.velocity, *data.velocity));
  EXPECT_EQ(back.id, data.id);
  EXPECT_EQ(back.time, data.time);
  EXPECT_EQ(back.attributes, data.attributes);
}

TEST_F(SnapshotTest, VelocitiesAreOptional) {
  const ParticleData data = makeData(20, false, 2);
  const fs::path file = dir_ / "novel.h5";
  writeSnapshot(file, data);
  const ParticleData back = readSnapshot(file);
  EXPECT_FALSE(back.velocity.has_value());
  EXPECT_TRUE(bitEqual(back.position, data.position));
  EXPECT_EQ(slurp(xdmfPath(file)).find("velocity"), std::string::npos);
}

TEST_F(SnapshotTest, EmptyConfigurationRoundTrips) {
  ParticleData data;
  data.box = Box::cubic(3.0, Boundary::Periodic);
  data.velocity = Eigen::Matrix3Xd(3, 0);
  const fs::path file = dir_ / "empty.hdf5";
  writeSnapshot(file, data);
  const ParticleData back = readSnapshot(file);
  EXPECT_EQ(back.count(), 0);
  EXPECT_TRUE(back.velocity.has_value());
  EXPECT_EQ(back.box, data.box);
}

TEST_F(SnapshotTest, XdmfSidecarReferencesDatasets) {
  ParticleData data = makeData(7, true, 3);
  data.attributes["a&b"] = "<x>";
  const fs::path file = dir_ / "frame.h5";
  writeSnapshot(file, data);
  const fs::path sidecar = dir_ / "frame.xmf";
  EXPECT_EQ(xdmfPath(file), sidecar);
  ASSERT_TRUE(fs::exists(sidecar));
  const std::string xml = slurp(sidecar);
  for (const char* part :
       {"<Xdmf Version=\"3.0\">", "TopologyType=\"Polyvertex\" NumberOfElements=\"7\"", "GeometryType=\"XYZ\"",
        "Dimensions=\"7 3\"", ">frame.h5:/particles/position<", ">frame.h5:/particles/radius<",
        ">frame.h5:/particles/id<", ">frame.h5:/particles/velocity<", "Name=\"radius\"", "Name=\"id\"",
        "Name=\"velocity\" AttributeType=\"Vector\"", "time = 0.33333333333333331 s", "NodesPerElement=\"1\">",
        "Dimensions=\"7 1\"", ">frame.h5:/xdmf/polyvertex<", "</Xdmf>"}) {
    EXPECT_NE(xml.find(part), std::string::npos) << part << "\n" << xml;
  }
  // meshio.read() accepts one grid of Topology, Geometry and Attribute elements only (issue 21): the time
  // and the parameters stay in the HDF5 file.
  for (const char* absent : {"<Time", "<Information", "a&amp;b"}) {
    EXPECT_EQ(xml.find(absent), std::string::npos) << absent << "\n" << xml;
  }
}

#if POLYDEM_WITH_HDF5
TEST_F(SnapshotTest, PolyvertexConnectivityIsZeroToNMinusOne) {
  writeSnapshot(dir_ / "c.h5", makeData(5, false, 3));
  const hid_t f = H5Fopen((dir_ / "c.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t d = H5Dopen2(f, "/xdmf/polyvertex", H5P_DEFAULT);
  ASSERT_GE(d, 0);
  std::int32_t v[5] = {-1, -1, -1, -1, -1};
  ASSERT_GE(H5Dread(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, v), 0);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(v[i], i);
  H5Dclose(d);
  H5Fclose(f);
}

TEST_F(SnapshotTest, ExtraArraysRoundTripAndAppearInTheSidecar) {
  ParticleData data = makeData(4, true, 8);
  data.arrays.push_back({"force", Eigen::MatrixXd::Random(3, 4)});
  data.arrays.push_back({"contact_count", Eigen::MatrixXd::Constant(1, 4, 2.0)});
  writeSnapshot(dir_ / "a.h5", data);
  const ParticleData back = readSnapshot(dir_ / "a.h5");
  ASSERT_EQ(back.arrays.size(), 2u);
  // Read back in name order.
  EXPECT_EQ(back.arrays[0].name, "contact_count");
  EXPECT_TRUE(bitEqual(back.arrays[0].values, data.arrays[1].values));
  EXPECT_EQ(back.arrays[1].name, "force");
  EXPECT_TRUE(bitEqual(back.arrays[1].values, data.arrays[0].values));
  const std::string xml = slurp(dir_ / "a.xmf");
  EXPECT_NE(xml.find("<Attribute Name=\"force\" AttributeType=\"Vector\""), std::string::npos) << xml;
  EXPECT_NE(xml.find(">a.h5:/particles/contact_count<"), std::string::npos) << xml;
}

TEST_F(SnapshotTest, BadExtraArraysAreConfigErrors) {
  ParticleData data = makeData(4, false, 8);
  data.arrays.push_back({"radius", Eigen::MatrixXd::Zero(1, 4)});
  EXPECT_THROW(writeSnapshot(dir_ / "a.h5", data), ConfigError);
  data.arrays.back() = {"bad name", Eigen::MatrixXd::Zero(1, 4)};
  EXPECT_THROW(writeSnapshot(dir_ / "a.h5", data), ConfigError);
  data.arrays.back() = {"two", Eigen::MatrixXd::Zero(2, 4)};
  EXPECT_THROW(writeSnapshot(dir_ / "a.h5", data), ConfigError);
}
#endif

TEST_F(SnapshotTest, PeriodicCoordinatesAreWrappedOnRead) {
  ParticleData data = makeData(2, false, 4);
  data.position(1, 0) = -0.25;  // y is periodic
  data.position(1, 1) = data.box.length(1) + 0.5;
  writeSnapshot(dir_ / "wrap.h5", data);
  const ParticleData back = readSnapshot(dir_ / "wrap.h5");
  EXPECT_EQ(back.position(1, 0), data.box.length(1) - 0.25);
  EXPECT_DOUBLE_EQ(back.position(1, 1), 0.5);
}

TEST_F(SnapshotTest, ReadAndWriteParticlesDispatchOnExtension) {
  const ParticleData data = makeData(5, true, 5);
  writeParticles(dir_ / "p.h5", data);
  EXPECT_TRUE(fs::exists(dir_ / "p.xmf"));
  const ParticleData back = readParticles(dir_ / "p.h5");
  EXPECT_EQ(back.id, data.id);  // text would have renumbered them
  EXPECT_EQ(back.time, data.time);
}

TEST_F(SnapshotTest, WriteRejectsBadArguments) {
  ParticleData data = makeData(3, false, 6);
  data.id.pop_back();
  EXPECT_THROW(writeSnapshot(dir_ / "a.h5", data), ConfigError);
  EXPECT_THROW(writeSnapshot(dir_ / "a.xmf", makeData(3, false, 6)), ConfigError);
  data = makeData(3, false, 6);
  data.attributes[""] = "x";
  EXPECT_THROW(writeSnapshot(dir_ / "a.h5", data), ConfigError);
}

TEST_F(SnapshotTest, WriteIntoMissingDirectoryNamesFile) {
  const fs::path file = dir_ / "missing" / "snap.h5";
  try {
    writeSnapshot(file, makeData(3, false, 7));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string() + ": cannot create HDF5 file"), std::string::npos) << e.what();
  }
}

// Issue 15: snapshots carry angular velocities (restart with friction is faithful).
TEST_F(SnapshotTest, AngularVelocitiesRoundTrip) {
  ParticleData data = makeData(40, true, 21);
  data.angularVelocity = Eigen::Matrix3Xd::Random(3, 40) * 1e3;
  const fs::path file = dir_ / "spin.h5";
  writeSnapshot(file, data);
  const ParticleData back = readSnapshot(file);
  ASSERT_TRUE(back.angularVelocity.has_value());
  EXPECT_TRUE(bitEqual(*back.angularVelocity, *data.angularVelocity));
  const std::string xml = slurp(xdmfPath(file));
  EXPECT_NE(xml.find("Name=\"angular_velocity\" AttributeType=\"Vector\""), std::string::npos) << xml;
  EXPECT_NE(xml.find(">spin.h5:/particles/angular_velocity<"), std::string::npos) << xml;
  // Without them the dataset is absent and reads back as absent.
  writeSnapshot(dir_ / "still.h5", makeData(3, true, 22));
  EXPECT_FALSE(readSnapshot(dir_ / "still.h5").angularVelocity.has_value());
}

TEST_F(SnapshotTest, NonFiniteAngularVelocityIsRefusedOnRead) {
  ParticleData data = makeData(2, false, 23);
  data.angularVelocity = Eigen::Matrix3Xd::Zero(3, 2);
  (*data.angularVelocity)(1, 1) = std::numeric_limits<double>::quiet_NaN();
  writeSnapshot(dir_ / "bad.h5", data);
  try {
    readSnapshot(dir_ / "bad.h5");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset /particles/angular_velocity: particle 1"), std::string::npos)
        << e.what();
  }
}

TEST_F(SnapshotTest, OneParticleRoundTrips) {
  ParticleData data = makeData(1, true, 24);
  data.angularVelocity = Eigen::Matrix3Xd::Constant(3, 1, 0.5);
  writeSnapshot(dir_ / "one.h5", data);
  const ParticleData back = readSnapshot(dir_ / "one.h5");
  EXPECT_EQ(back.count(), 1);
  EXPECT_EQ(back.id, data.id);
  EXPECT_TRUE(bitEqual(*back.angularVelocity, *data.angularVelocity));
}

// Issue 15: the same data written twice gives the same bytes (no object time stamps), so resumed runs
// can be compared with cmp.
TEST_F(SnapshotTest, SameDataGivesSameBytes) {
  ParticleData data = makeData(50, true, 25);
  data.angularVelocity = Eigen::Matrix3Xd::Random(3, 50);
  data.attributes = {{"reduced_pressure", "1e12"}, {"seed", "3"}};
  writeSnapshot(dir_ / "a.h5", data);
  const std::string first = slurp(dir_ / "a.h5");
  sleep(1);  // HDF5 time stamps have a resolution of one second
  writeSnapshot(dir_ / "b.h5", data);
  writeSnapshot(dir_ / "a.h5", data);  // replacing an existing file too
  EXPECT_EQ(first, slurp(dir_ / "b.h5"));
  EXPECT_EQ(first, slurp(dir_ / "a.h5"));
  EXPECT_FALSE(first.empty());
}

std::vector<std::string> listDirectory(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Issue 15: a snapshot write that fails part way (here: a file-size limit, as on a full disk) leaves the
// previous snapshot and its sidecar intact and no temporary behind.
TEST_F(SnapshotTest, FailedWriteKeepsOldSnapshotAndLeavesNoTemporary) {
  const fs::path file = dir_ / "state.h5";
  writeSnapshot(file, makeData(3, false, 26));
  const std::string oldBytes = slurp(file);
  const std::string oldXml = slurp(xdmfPath(file));
  const ParticleData big = makeData(20000, true, 27);  // about 1.3 MB of datasets
  {
    rlimit saved{};
    getrlimit(RLIMIT_FSIZE, &saved);
    const auto previous = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved;
    limit.rlim_cur = 200000;
    setrlimit(RLIMIT_FSIZE, &limit);
    EXPECT_THROW(writeSnapshot(file, big), InputError);
    setrlimit(RLIMIT_FSIZE, &saved);
    std::signal(SIGXFSZ, previous);
  }
  EXPECT_EQ(slurp(file), oldBytes);
  EXPECT_EQ(slurp(xdmfPath(file)), oldXml);
  EXPECT_EQ(readSnapshot(file).count(), 3);
  EXPECT_EQ(listDirectory(dir_), (std::vector<std::string>{"state.h5", "state.xmf"}));
}

// ---------------------------------------------------------------------------------------------------
// Malformed snapshots: write a valid one, damage it with the C API, expect "FILE: dataset PATH: problem".

/// Open `file` read-write, run `edit` on it, close.
void editSnapshot(const fs::path& file, const std::function<void(hid_t)>& edit) {
  const hid_t f = H5Fopen(file.string().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  edit(f);
  ASSERT_GE(H5Fclose(f), 0);
}

/// Replace dataset `path` with one of the given shape and types holding `values`.
void replaceDataset(hid_t f, const char* path, hid_t fileType, hid_t memoryType, std::vector<hsize_t> dims,
                    const void* values) {
  if (H5Lexists(f, path, H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Ldelete(f, path, H5P_DEFAULT), 0);
  }
  const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  const hid_t dataset = H5Dcreate2(f, path, fileType, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(dataset, 0);
  ASSERT_GE(H5Dwrite(dataset, memoryType, H5S_ALL, H5S_ALL, H5P_DEFAULT, values), 0);
  H5Dclose(dataset);
  H5Sclose(space);
}

void replaceDoubles(hid_t f, const char* path, std::vector<hsize_t> dims, const std::vector<double>& values) {
  replaceDataset(f, path, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, std::move(dims), values.data());
}

std::vector<double> rowsOf(const Eigen::Matrix3Xd& m) { return {m.data(), m.data() + m.size()}; }

struct Damage {
  std::string name;
  std::function<void(hid_t, const ParticleData&)> edit;
  std::vector<std::string> problem;  // substrings of the message after "FILE: "
};

void PrintTo(const Damage& d, std::ostream* os) { *os << d.name; }

class SnapshotErrors : public SnapshotTest, public ::testing::WithParamInterface<Damage> {};

TEST_P(SnapshotErrors, ThrowInputErrorNamingFileDatasetAndProblem) {
  const Damage& d = GetParam();
  const ParticleData data = makeData(100, true, 11);
  const fs::path file = dir_ / "snap.h5";
  writeSnapshot(file, data);
  editSnapshot(file, [&](hid_t f) { d.edit(f, data); });
  try {
    readSnapshot(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0u) << message;
    for (const std::string& part : d.problem) EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

const Damage kDamages[] = {
    {"ShortRadius",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> r(data.radius.data(), data.radius.data() + 99);
       replaceDoubles(f, "/particles/radius", {99}, r);
     },
     {"snap.h5: dataset /particles/radius: expected 100 entries, got 99"}},
    {"RadiusTwoDimensional",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> r(data.radius.data(), data.radius.data() + 100);
       replaceDoubles(f, "/particles/radius", {100, 1}, r);
     },
     {"dataset /particles/radius: expected a 1-d array of 100 entries, got shape 100 x 1"}},
    {"MissingRadius",
     [](hid_t f, const ParticleData&) { H5Ldelete(f, "/particles/radius", H5P_DEFAULT); },
     {"dataset /particles/radius: missing"}},
    {"MissingParticlesGroup",
     [](hid_t f, const ParticleData&) { H5Ldelete(f, "/particles", H5P_DEFAULT); },
     {"dataset /particles/position: missing"}},
    {"MissingBox",
     [](hid_t f, const ParticleData&) { H5Ldelete(f, "/box/lengths", H5P_DEFAULT); },
     {"dataset /box/lengths: missing"}},
    {"PositionTwoColumns",
     [](hid_t f, const ParticleData&) {
       replaceDoubles(f, "/particles/position", {100, 2}, std::vector<double>(200, 0.01));
     },
     {"dataset /particles/position: expected shape N x 3, got shape 100 x 2"}},
    {"LongVelocity",
     [](hid_t f, const ParticleData&) {
       replaceDoubles(f, "/particles/velocity", {101, 3}, std::vector<double>(303, 0.0));
     },
     {"dataset /particles/velocity: expected 100 rows of 3, got 101"}},
    {"ShortId",
     [](hid_t f, const ParticleData& data) {
       replaceDataset(f, "/particles/id", H5T_STD_I32LE, H5T_NATIVE_INT32, {50}, data.id.data());
     },
     {"dataset /particles/id: expected 100 entries, got 50"}},
    {"FloatingIds",
     [](hid_t f, const ParticleData&) { replaceDoubles(f, "/particles/id", {100}, std::vector<double>(100, 1.5)); },
     {"dataset /particles/id: expected integers, got floating-point numbers"}},
    {"NanPosition",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> x = rowsOf(data.position);
       x[3 * 5 + 1] = std::numeric_limits<double>::quiet_NaN();
       replaceDoubles(f, "/particles/position", {100, 3}, x);
     },
     {"dataset /particles/position: particle 5 (id 285): y = nan is not finite"}},
    {"InfVelocity",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> v = rowsOf(*data.velocity);
       v[3 * 7 + 2] = -std::numeric_limits<double>::infinity();
       replaceDoubles(f, "/particles/velocity", {100, 3}, v);
     },
     {"dataset /particles/velocity: particle 7", "vz = -inf is not finite"}},
    {"NegativeRadius",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> r(data.radius.data(), data.radius.data() + 100);
       r[9] = -0.5;
       replaceDoubles(f, "/particles/radius", {100}, r);
     },
     {"dataset /particles/radius: particle 9 (id 273): radius must be positive and finite, got -0.5"}},
    {"ZeroRadius",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> r(data.radius.data(), data.radius.data() + 100);
       r[0] = 0.0;
       replaceDoubles(f, "/particles/radius", {100}, r);
     },
     {"dataset /particles/radius: particle 0", "radius must be positive"}},
    {"NanRadius",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> r(data.radius.data(), data.radius.data() + 100);
       r[99] = std::numeric_limits<double>::quiet_NaN();
       replaceDoubles(f, "/particles/radius", {100}, r);
     },
     {"dataset /particles/radius: particle 99", "got nan"}},
    {"DuplicateIds",
     [](hid_t f, const ParticleData& data) {
       std::vector<Index> ids = data.id;
       ids[60] = ids[20];
       replaceDataset(f, "/particles/id", H5T_STD_I32LE, H5T_NATIVE_INT32, {100}, ids.data());
     },
     {"dataset /particles/id: id 240 appears twice (particles 20 and 60)"}},
    {"NegativeId",
     [](hid_t f, const ParticleData& data) {
       std::vector<std::int64_t> ids(data.id.begin(), data.id.end());
       ids[3] = -1;
       replaceDataset(f, "/particles/id", H5T_STD_I64LE, H5T_NATIVE_INT64, {100}, ids.data());
     },
     {"dataset /particles/id: particle 3: id -1 is outside"}},
    {"OutsideWall",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> x = rowsOf(data.position);
       x[3 * 4 + 0] = 10.5;  // x is walled, L = 10
       replaceDoubles(f, "/particles/position", {100, 3}, x);
     },
     {"dataset /particles/position: particle 4 (id 288): x = 10.5 is outside the walled box [0, 10] along x"}},
    {"BelowWall",
     [](hid_t f, const ParticleData& data) {
       std::vector<double> x = rowsOf(data.position);
       x[3 * 4 + 2] = -1e-9;  // z is walled
       replaceDoubles(f, "/particles/position", {100, 3}, x);
     },
     {"dataset /particles/position: particle 4", "outside the walled box [0, 0.1] along z"}},
    {"ZeroBoxLength",
     [](hid_t f, const ParticleData&) {
       replaceDoubles(f, "/box/lengths", {3}, {10, 0, 1});
     },
     {"dataset /box/lengths: box length along y must be positive and finite, got 0"}},
    {"BoxLengthsTwoEntries",
     [](hid_t f, const ParticleData&) {
       replaceDoubles(f, "/box/lengths", {2}, {10, 1});
     },
     {"dataset /box/lengths: expected 3 entries, got 2"}},
    {"PeriodicFlagTwo",
     [](hid_t f, const ParticleData&) {
       const std::int8_t flags[3] = {0, 2, 0};
       replaceDataset(f, "/box/periodic", H5T_STD_I8LE, H5T_NATIVE_INT8, {3}, flags);
     },
     {"dataset /box/periodic: entry 1 (y) must be 1 (periodic) or 0 (wall), got 2"}},
    {"WallBecomesOutside",
     [](hid_t f, const ParticleData&) {
       // Wall off y and shrink it to 0.5: centres were spread over the old periodic length 7.25.
       replaceDoubles(f, "/box/lengths", {3}, {10, 0.5, 0.1});
       const std::int32_t flags[3] = {0, 0, 0};
       replaceDataset(f, "/box/periodic", H5T_STD_I32LE, H5T_NATIVE_INT32, {3}, flags);
     },
     {"dataset /particles/position: particle", "outside the walled box [0, 0.5] along y"}},
    {"NonStringParameter",
     [](hid_t f, const ParticleData&) {
       const hid_t group = H5Gopen2(f, "/parameters", H5P_DEFAULT);
       const hid_t space = H5Screate(H5S_SCALAR);
       const hid_t attribute = H5Acreate2(group, "dt", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT);
       const double dt = 1e-6;
       H5Awrite(attribute, H5T_NATIVE_DOUBLE, &dt);
       H5Aclose(attribute);
       H5Sclose(space);
       H5Gclose(group);
     },
     {"attribute /parameters/dt: expected a string, got floating-point numbers"}},
    {"StringTime",
     [](hid_t f, const ParticleData&) {
       H5Adelete(f, "time");
       const hid_t type = H5Tcopy(H5T_C_S1);
       H5Tset_size(type, 4);
       const hid_t space = H5Screate(H5S_SCALAR);
       const hid_t attribute = H5Acreate2(f, "time", type, space, H5P_DEFAULT, H5P_DEFAULT);
       H5Awrite(attribute, type, "late");
       H5Aclose(attribute);
       H5Sclose(space);
       H5Tclose(type);
     },
     {"attribute /time: expected a number, got strings"}},
};

INSTANTIATE_TEST_SUITE_P(Damaged, SnapshotErrors, ::testing::ValuesIn(kDamages),
                         [](const ::testing::TestParamInfo<Damage>& info) { return info.param.name; });

TEST_F(SnapshotTest, ForeignLayoutVariantsAreAccepted) {
  // Written by other tools: fixed-length string parameters, int32 periodic flags, no time, float32
  // radii, int64 ids.
  const ParticleData data = makeData(4, false, 12);
  const fs::path file = dir_ / "foreign.h5";
  writeSnapshot(file, data);
  editSnapshot(file, [&](hid_t f) {
    const hid_t group = H5Gopen2(f, "/parameters", H5P_DEFAULT);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 5);  // exactly "hertz", no terminator
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t attribute = H5Acreate2(group, "law", type, space, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(attribute, type, "hertz");
    H5Aclose(attribute);
    H5Sclose(space);
    H5Tclose(type);
    H5Gclose(group);
    H5Adelete(f, "time");
    const std::int32_t flags[3] = {0, 1, 0};
    replaceDataset(f, "/box/periodic", H5T_STD_I32LE, H5T_NATIVE_INT32, {3}, flags);
    const float radii[4] = {0.5f, 0.25f, 0.125f, 1.0f};
    replaceDataset(f, "/particles/radius", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {4}, radii);
    const std::int64_t ids[4] = {7, 8, 9, 10};
    replaceDataset(f, "/particles/id", H5T_STD_I64LE, H5T_NATIVE_INT64, {4}, ids);
  });
  const ParticleData back = readSnapshot(file);
  EXPECT_EQ(back.attributes.at("law"), "hertz");
  EXPECT_EQ(back.time, 0.0);
  EXPECT_EQ(back.box, data.box);
  EXPECT_EQ(back.radius, Eigen::Vector4d(0.5, 0.25, 0.125, 1.0));
  EXPECT_EQ(back.id, (std::vector<Index>{7, 8, 9, 10}));
}

TEST_F(SnapshotTest, NotAnHdf5File) {
  const fs::path file = dir_ / "fake.h5";
  std::ofstream(file) << "1 1 1 1\n0.5 0.5 0.5 0.1\n";
  try {
    readSnapshot(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": not an HDF5 file");
  }
}

TEST_F(SnapshotTest, MissingFile) {
  const fs::path file = dir_ / "absent.h5";
  try {
    readParticles(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": no such file");
  }
}

TEST_F(SnapshotTest, HdfErrorPrintingIsRestored) {
  // We silence HDF5 only while working; a caller's handler must survive our calls, even failing ones.
  H5E_auto2_t before = nullptr;
  void* beforeData = nullptr;
  H5Eget_auto2(H5E_DEFAULT, &before, &beforeData);
  EXPECT_THROW(readSnapshot(dir_ / "absent.h5"), InputError);
  const fs::path fake = dir_ / "fake.h5";
  std::ofstream(fake) << "x";
  EXPECT_THROW(readSnapshot(fake), InputError);
  writeSnapshot(dir_ / "ok.h5", makeData(2, false, 13));
  H5E_auto2_t after = nullptr;
  void* afterData = nullptr;
  H5Eget_auto2(H5E_DEFAULT, &after, &afterData);
  EXPECT_EQ(after, before);
  EXPECT_EQ(afterData, beforeData);
}

#endif  // POLYDEM_WITH_HDF5

}  // namespace
}  // namespace polydem::io
