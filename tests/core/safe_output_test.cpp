// Output safety (issue 15): output paths checked before a run, atomic replacement, attribute parsing.
#include "core/io/safe_output.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"

namespace fs = std::filesystem;
using namespace polydem;

namespace {

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("polydem-safe-output-{}", ::getpid());
  fs::create_directories(dir);
  return dir / name;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST(CheckOutputPath, RefusesMissingDirectory) {
  EXPECT_THROW(io::checkOutputPath(scratch("no-such-dir/x.h5"), "-o"), ConfigError);
  try {
    io::checkOutputPath(scratch("no-such-dir/x.h5"), "--output");
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("--output"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos);
  }
}

TEST(CheckOutputPath, RefusesDirectoryAndInputAlias) {
  const fs::path in = scratch("scene.toml");
  std::ofstream(in) << "x";
  EXPECT_THROW(io::checkOutputPath(in.parent_path(), "-o"), ConfigError);
  const fs::path inputs[] = {in};
  EXPECT_THROW(io::checkOutputPath(in, "output.timeseries", inputs), ConfigError);
  // The same file under another spelling is still the input.
  const fs::path alias = in.parent_path() / "." / "scene.toml";
  EXPECT_THROW(io::checkOutputPath(alias, "output.timeseries", inputs), ConfigError);
  EXPECT_NO_THROW(io::checkOutputPath(scratch("other.csv"), "output.timeseries", inputs));
}

TEST(CheckOutputPath, RefusesUnwritableDirectory) {
  if (::geteuid() == 0) {
    // Root passes every permission bit, but not the kernel's refusal to create files in /proc/1.
    if (::access("/proc/1", W_OK) == 0) GTEST_SKIP() << "root can write to /proc/1 here";
    EXPECT_THROW(io::checkOutputPath("/proc/1/x.txt", "-o"), ConfigError);
    return;
  }
  const fs::path dir = scratch("readonly");
  fs::create_directories(dir);
  ::chmod(dir.c_str(), 0555);
  EXPECT_THROW(io::checkOutputPath(dir / "x.txt", "-o"), ConfigError);
  ::chmod(dir.c_str(), 0755);
}

TEST(AtomicFile, ReplacesOnlyOnCommit) {
  const fs::path target = scratch("atomic.txt");
  io::writeFileAtomically(target, "old\n");
  {
    io::AtomicFile f(target);
    std::ofstream(f.temporary()) << "half";
    EXPECT_EQ(f.temporary().parent_path(), target.parent_path());
    // destroyed without commit: the old content stays, the temporary is gone
  }
  EXPECT_EQ(slurp(target), "old\n");
  for (const auto& e : fs::directory_iterator(target.parent_path())) {
    EXPECT_EQ(e.path().filename().string().find(".atomic.txt.tmp"), std::string::npos) << e.path();
  }
  {
    io::AtomicFile f(target);
    std::ofstream(f.temporary()) << "new\n";
    f.commit();
  }
  EXPECT_EQ(slurp(target), "new\n");
}

TEST(Attributes, ParseFiniteDoubleIsStrict) {
  EXPECT_EQ(io::parseFiniteDouble("1e12"), 1e12);
  EXPECT_EQ(io::parseFiniteDouble(" 2.5 "), 2.5);
  EXPECT_FALSE(io::parseFiniteDouble("20x"));
  EXPECT_FALSE(io::parseFiniteDouble(""));
  EXPECT_FALSE(io::parseFiniteDouble("nan"));
  EXPECT_FALSE(io::parseFiniteDouble("inf"));
  EXPECT_FALSE(io::parseFiniteDouble("1e999"));
}

TEST(Attributes, MalformedAttributeNamesFileAndKey) {
  io::ParticleData data;
  data.attributes["reduced_pressure"] = "abc";
  try {
    (void)io::numericAttribute(data, "reduced_pressure", "pack.h5");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("pack.h5"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("reduced_pressure"), std::string::npos);
  }
  EXPECT_FALSE(io::numericAttribute(data, "absent", "pack.h5"));
  EXPECT_THROW((void)io::requireNumericAttribute(data, "absent", "pack.h5"), InputError);
}

TEST(Interrupt, FlagSetBySignal) {
  installInterruptHandlers();
  clearInterrupt();
  EXPECT_FALSE(interruptRequested());
  std::raise(SIGTERM);
  EXPECT_TRUE(interruptRequested());
  EXPECT_EQ(interruptSignal(), SIGTERM);
  clearInterrupt();
}

#include "core/io/checkpoint.hpp"
#include "polydem/config.hpp"

TEST(Checkpoint, RoundTripIsBitExact) {
#if !POLYDEM_WITH_HDF5
  GTEST_SKIP() << "built without HDF5";
#else
  io::Checkpoint c;
  c.kind = "test";
  Eigen::Matrix3Xd m = Eigen::Matrix3Xd::Random(3, 7);
  c.putMatrix("position", m);
  c.putScalar("time", 0.1 + 0.2);
  c.putInteger("step", 123456789012LL);
  c.integer["empty"] = {};
  c.text["schedule"] = "1e-2:1e2,1e-3";
  c.text["blank"] = "";
  const fs::path file = scratch("state.h5");
  io::writeCheckpoint(file, c);
  const io::Checkpoint r = io::readCheckpoint(file, "test");
  EXPECT_EQ(r.kind, "test");
  const Eigen::Matrix3Xd back = r.matrix("position", 7);
  EXPECT_EQ(std::memcmp(back.data(), m.data(), sizeof(double) * 21), 0);
  EXPECT_EQ(r.scalar("time"), 0.1 + 0.2);
  EXPECT_EQ(r.integerScalar("step"), 123456789012LL);
  EXPECT_TRUE(r.integers("empty").empty());
  EXPECT_EQ(r.string("schedule"), "1e-2:1e2,1e-3");
  EXPECT_EQ(r.string("blank"), "");
  EXPECT_THROW((void)r.matrix("position", 8), InputError);
  EXPECT_THROW((void)r.scalar("absent"), InputError);
  EXPECT_THROW((void)io::readCheckpoint(file, "relax"), InputError);
#endif
}

TEST(Checkpoint, SameStateWrittenTwiceIsByteIdentical) {
#if !POLYDEM_WITH_HDF5
  GTEST_SKIP() << "built without HDF5";
#else
  // Object time stamps would make two writes of the same state differ; a second apart they would show.
  io::Checkpoint c;
  c.kind = "test";
  c.putMatrix("position", Eigen::Matrix3Xd::Random(3, 5));
  c.putInteger("step", 42);
  c.text["schedule"] = "1e-2:1e2";
  const fs::path first = scratch("twice-1.h5");
  const fs::path second = scratch("twice-2.h5");
  io::writeCheckpoint(first, c);
  ::sleep(1);
  io::writeCheckpoint(second, c);
  std::ifstream a(first, std::ios::binary), b(second, std::ios::binary);
  const std::string bytesA((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
  const std::string bytesB((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(bytesA.empty());
  EXPECT_EQ(bytesA, bytesB);
#endif
}
