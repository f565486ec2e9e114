#include "core/io/xdmf.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace polydem::io {
namespace {

XdmfFrame frame(const std::string& h5, double time, Index n, double length) {
  XdmfFrame f;
  f.h5 = h5;
  f.time = time;
  f.count = n;
  f.boxLengths = Eigen::Vector3d(length, 2.0, 3.0);
  f.velocity = true;
  return f;
}

std::size_t countOf(const std::string& text, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

TEST(Xdmf, SeriesHoldsABoxAndAParticleCollectionWithOneTimePerFrame) {
  const std::vector<XdmfFrame> frames = {frame("run/s_0.h5", 0.0, 10, 1.0), frame("run/s_1.h5", 0.5, 10, 0.9)};
  const std::string xml = xdmfSeriesXml(frames, "run/s_series.xmf");
  EXPECT_EQ(countOf(xml, "CollectionType=\"Temporal\""), 2u) << xml;
  // The particle collection comes last: meshio's TimeSeriesReader takes the last collection.
  EXPECT_LT(xml.find("<Grid Name=\"box\" GridType=\"Collection\""),
            xml.find("<Grid Name=\"particles\" GridType=\"Collection\""));
  EXPECT_EQ(countOf(xml, "<Time Value=\"0.5\"/>"), 2u);
  EXPECT_EQ(countOf(xml, "<Time Value=\"0\"/>"), 2u);
  EXPECT_EQ(countOf(xml, ">s_1.h5:/particles/position<"), 2u) << "geometry and the position attribute";
  EXPECT_EQ(countOf(xml, ">s_0.h5:/xdmf/polyvertex<"), 1u);
  EXPECT_NE(xml.find("TopologyType=\"Polyline\" NumberOfElements=\"12\" NodesPerElement=\"2\""), std::string::npos);
  // The second frame's box is 0.9 long along x: its far corner.
  EXPECT_NE(xml.find("0.90000000000000002 2 3</DataItem>"), std::string::npos) << xml;
}

TEST(Xdmf, PathsAreRelativeToTheXmfDirectory) {
  const std::string xml = xdmfSeriesXml(std::vector<XdmfFrame>{frame("a/b/s.h5", 0, 1, 1)}, "a/series.xmf");
  EXPECT_NE(xml.find(">b/s.h5:/particles/radius<"), std::string::npos) << xml;
}

TEST(Xdmf, SeriesPathForAPattern) {
  EXPECT_EQ(seriesPathFor("out/snap_{step}.h5"), std::filesystem::path("out/snap_series.xmf"));
  EXPECT_EQ(seriesPathFor("final.h5"), std::filesystem::path("final_series.xmf"));
}

}  // namespace
}  // namespace polydem::io
