// Contact files (core/io/contacts.hpp): CSV and HDF5 writers, the HDF5 reader, the XDMF line cells and
// series, paths, and bad data.
#include "core/io/contacts.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/xdmf.hpp"
#include "polydem/config.hpp"

namespace polydem::io {
namespace {

namespace fs = std::filesystem;

class ContactFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           (std::string("polydem_contacts_") + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

/// Two contacts in a periodic box of 10 x 10 x 10, the second across the x boundary.
ContactData twoContacts(bool tangential) {
  ContactData d;
  d.box = Box(Eigen::Vector3d(10.0, 10.0, 10.0), kAllPeriodic);
  d.time = 1.25;
  d.attributes = {{"step", "100"}, {"snapshot", "s_000000100.h5"}};
  d.idI = {0, 3};
  d.idJ = {4, 7};
  d.centre.resize(3, 2);
  d.centre.col(0) << 5.0, 5.0, 5.0;
  d.centre.col(1) << 0.25, 2.0, 3.0;
  d.branch.resize(3, 2);
  d.branch.col(0) << 1.5, 0.0, 0.0;   // |b| = 1.5
  d.branch.col(1) << -0.6, 0.0, 0.8;  // |b| = 1.0: to the image of j at x = -0.35
  d.overlap = Eigen::Vector2d(0.1, 0.05);
  d.normalForce = Eigen::Vector2d(2.0, -0.5);
  if (tangential) {
    d.tangentialForce = Eigen::Matrix3Xd(3, 2);
    d.tangentialForce->col(0) << 0.0, 0.25, 0.0;
    d.tangentialForce->col(1) << 0.1, 0.0, 0.075;
  }
  return d;
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::size_t countOf(const std::string& text, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

TEST(ContactData, NormalForceVectorPointsFromJToI) {
  const ContactData d = twoContacts(false);
  // Repulsive fn = 2 along -branch / |branch| = -x.
  EXPECT_EQ(d.normalForceVector(0), Eigen::Vector3d(-2.0, 0.0, 0.0));
  // fn = -0.5 (a damped contact pulling at its end): along +branch.
  EXPECT_DOUBLE_EQ(d.normalForceVector(1)[0], -0.3);
  EXPECT_DOUBLE_EQ(d.normalForceVector(1)[2], 0.4);
}

TEST_F(ContactFileTest, CsvHasAHeaderAndOneRowPerContactAtFullPrecision) {
  const fs::path file = dir_ / "c.csv";
  ContactData d = twoContacts(true);
  d.overlap[0] = 0.1 + 1e-16 * 3;  // needs 17 digits
  writeContacts(file, d);
  std::stringstream in(slurp(file));
  std::vector<std::string> comments, rows;
  for (std::string line; std::getline(in, line);) (line.starts_with("#") ? comments : rows).push_back(line);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(slurp(file).starts_with("id_i,id_j,")) << "column names first, for numpy.genfromtxt(names=True)";
  EXPECT_EQ(rows[0],
            "id_i,id_j,overlap,fn,normal_force_x,normal_force_y,normal_force_z,tangential_force_x,"
            "tangential_force_y,tangential_force_z,branch_x,branch_y,branch_z,centre_x,centre_y,centre_z");
  EXPECT_EQ(rows[1], fmt::format("0,4,{:.17g},2,-2,-0,-0,0,0.25,0,1.5,0,0,5,5,5", d.overlap[0]));
  EXPECT_TRUE(rows[2].starts_with("3,7,0.050000000000000003,-0.5,")) << rows[2];
  EXPECT_NE(std::find(comments.begin(), comments.end(), "# time: 1.25"), comments.end());
  EXPECT_NE(std::find(comments.begin(), comments.end(), "# box: 10 10 10 periodic periodic periodic"), comments.end());
  EXPECT_NE(std::find(comments.begin(), comments.end(), "# attribute: step = 100"), comments.end());
}

TEST_F(ContactFileTest, CsvWithoutTangentialForceHasNoTangentialColumns) {
  const fs::path file = dir_ / "c.txt";
  writeContacts(file, twoContacts(false));
  const std::string text = slurp(file);
  EXPECT_EQ(text.find("tangential"), std::string::npos) << text;
  EXPECT_NE(text.find("id_i,id_j,overlap,fn,normal_force_x,normal_force_y,normal_force_z,branch_x"), std::string::npos);
}

TEST_F(ContactFileTest, NoContactsIsAHeaderOnly) {
  ContactData d;
  d.box = Box(Eigen::Vector3d(1.0, 1.0, 1.0), kAllPeriodic);
  writeContacts(dir_ / "none.csv", d);
  const std::string text = slurp(dir_ / "none.csv");
  EXPECT_NE(text.find("# polydem contacts: 0 particle pairs in contact"), std::string::npos);
  EXPECT_TRUE(text.starts_with("id_i,")) << text;
  EXPECT_TRUE(text.ends_with("centre in the box\n")) << "comments, no rows: " << text;
}

TEST(ContactData, InconsistentDataIsRefusedBeforeWriting) {
  ContactData d = twoContacts(true);
  d.branch.resize(3, 1);
  EXPECT_THROW(requireConsistentContacts(d), ConfigError);
  d = twoContacts(true);
  d.idJ.pop_back();
  EXPECT_THROW(requireConsistentContacts(d), ConfigError);
  d = twoContacts(true);
  d.tangentialForce->resize(3, 3);
  EXPECT_THROW(requireConsistentContacts(d), ConfigError);
  d = twoContacts(false);
  d.idJ[1] = d.idI[1];  // a particle in contact with itself
  try {
    requireConsistentContacts(d);
    ADD_FAILURE() << "no exception";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("row 1: ids (3, 3) must satisfy 0 <= id_i < id_j"), std::string::npos)
        << e.what();
  }
}

TEST_F(ContactFileTest, InconsistentDataLeavesNoFile) {
  ContactData d = twoContacts(false);
  d.normalForce.resize(1);
  EXPECT_THROW(writeContacts(dir_ / "bad.csv", d), ConfigError);
  EXPECT_FALSE(fs::exists(dir_ / "bad.csv"));
}

TEST(ContactPaths, BesideTheSnapshotWithItsFormat) {
  EXPECT_EQ(contactPathFor("out/s_000000100.h5"), fs::path("out/s_000000100_contacts.h5"));
  EXPECT_EQ(contactPathFor("s.HDF5"), fs::path("s_contacts.HDF5"));
  EXPECT_EQ(contactPathFor("out/s_000000100.txt"), fs::path("out/s_000000100_contacts.csv"));
  EXPECT_EQ(contactPathFor("s.dump"), fs::path("s_contacts.csv"));
  EXPECT_EQ(contactXdmfPath("out/s_contacts.h5"), fs::path("out/s_contacts.xmf"));
  EXPECT_EQ(contactSeriesPathFor("out/snap_{step}.h5"), fs::path("out/snap_contacts_series.xmf"));
  EXPECT_EQ(contactSeriesPathFor("final.h5"), fs::path("final_contacts_series.xmf"));
}

TEST(ContactXdmf, SidecarIsOneGridOfTwoNodeLinesWithCellAttributes) {
  const XdmfContactFrame f = xdmfContactFrameOf("run/c.h5", twoContacts(true));
  const std::string xml = xdmfContactXml(f, "run/c.xmf");
  EXPECT_EQ(countOf(xml, "<Grid "), 1u) << xml;
  EXPECT_EQ(countOf(xml, "<Time"), 0u) << "meshio.read() rejects Time in a single grid";
  EXPECT_NE(xml.find("TopologyType=\"Polyline\" NumberOfElements=\"2\" NodesPerElement=\"2\""), std::string::npos);
  EXPECT_NE(xml.find("Dimensions=\"2 2\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">c.h5:/xdmf/lines<"),
            std::string::npos)
      << xml;
  EXPECT_NE(xml.find("Dimensions=\"4 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">c.h5:/xdmf/points<"),
            std::string::npos);
  for (const char* name : {"fn", "normal_force", "tangential_force", "overlap", "branch", "id_i", "id_j"}) {
    EXPECT_NE(xml.find(fmt::format("<Attribute Name=\"{}\"", name)), std::string::npos) << name;
  }
  EXPECT_EQ(countOf(xml, "Center=\"Cell\""), 7u);
  EXPECT_EQ(countOf(xml, "Center=\"Node\""), 0u);
  const std::string frictionless = xdmfContactXml(xdmfContactFrameOf("c.h5", twoContacts(false)), "c.xmf");
  EXPECT_EQ(frictionless.find("tangential_force"), std::string::npos);
}

TEST(ContactXdmf, SeriesHasOneFrameAndTimePerFileWithContactsLast) {
  ContactData a = twoContacts(false), b = twoContacts(false);
  b.time = 2.5;
  const std::vector<XdmfContactFrame> frames = {xdmfContactFrameOf("run/c_0.h5", a),
                                                xdmfContactFrameOf("run/c_1.h5", b)};
  const std::string xml = xdmfContactSeriesXml(frames, "run/c_series.xmf");
  EXPECT_EQ(countOf(xml, "CollectionType=\"Temporal\""), 2u);
  EXPECT_LT(xml.find("<Grid Name=\"box\" GridType=\"Collection\""),
            xml.find("<Grid Name=\"contacts\" GridType=\"Collection\""));
  EXPECT_EQ(countOf(xml, "<Time Value=\"2.5\"/>"), 2u) << "box and contacts";
  EXPECT_EQ(countOf(xml, ">c_1.h5:/xdmf/points<"), 2u) << "geometry and the position attribute";
  EXPECT_EQ(countOf(xml, "<Attribute Name=\"position\" AttributeType=\"Vector\" Center=\"Node\">"), 2u);
}

#if POLYDEM_WITH_HDF5

TEST_F(ContactFileTest, Hdf5RoundTripsEveryFieldBitExactly) {
  const fs::path file = dir_ / "c_contacts.h5";
  const ContactData d = twoContacts(true);
  writeContacts(file, d);
  ASSERT_TRUE(fs::exists(dir_ / "c_contacts.xmf"));
  const ContactData r = readContacts(file);
  EXPECT_EQ(r.idI, d.idI);
  EXPECT_EQ(r.idJ, d.idJ);
  EXPECT_EQ(r.centre, d.centre);
  EXPECT_EQ(r.branch, d.branch);
  EXPECT_EQ(r.overlap, d.overlap);
  EXPECT_EQ(r.normalForce, d.normalForce);
  ASSERT_TRUE(r.tangentialForce.has_value());
  EXPECT_EQ(*r.tangentialForce, *d.tangentialForce);
  EXPECT_EQ(r.time, 1.25);
  EXPECT_EQ(r.attributes, d.attributes);
  EXPECT_EQ(r.box.lengths(), d.box.lengths());
  const std::string xml = slurp(dir_ / "c_contacts.xmf");
  EXPECT_NE(xml.find(">c_contacts.h5:/contacts/fn<"), std::string::npos) << xml;
  // Without friction the file has no tangential dataset.
  writeContacts(dir_ / "f.h5", twoContacts(false));
  EXPECT_FALSE(readContacts(dir_ / "f.h5").tangentialForce.has_value());
}

TEST_F(ContactFileTest, Hdf5OfNoContactsReadsBack) {
  ContactData d;
  d.box = Box(Eigen::Vector3d(1.0, 2.0, 3.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  writeContacts(dir_ / "none.h5", d);
  const ContactData r = readContacts(dir_ / "none.h5");
  EXPECT_EQ(r.count(), 0);
  EXPECT_FALSE(r.box.periodic(2));
}

TEST_F(ContactFileTest, ReadingASnapshotAsAContactFileNamesTheMissingDataset) {
  ParticleData p;
  p.position = Eigen::Matrix3Xd::Constant(3, 1, 0.5);
  p.radius = Eigen::VectorXd::Constant(1, 0.1);
  p.id = {0};
  writeSnapshot(dir_ / "s.h5", p);
  try {
    readContacts(dir_ / "s.h5");
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset /contacts/overlap: missing"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readContacts(dir_ / "missing.h5"), InputError);
}

#endif

}  // namespace
}  // namespace polydem::io
