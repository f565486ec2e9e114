// XDMF 3 sidecars and temporal series, see xdmf.hpp for what each reader needs.
#include "core/io/xdmf.hpp"

#include <fmt/format.h>

#include <string_view>

#include "core/io/safe_output.hpp"

namespace polydem::io {

namespace {

std::string xmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// `h5` as seen from the directory of `xmf`: the bare file name when they sit side by side.
std::string relativeName(const std::filesystem::path& h5, const std::filesystem::path& xmf) {
  std::error_code ec;
  const std::filesystem::path a = std::filesystem::absolute(h5, ec).lexically_normal();
  const std::filesystem::path b = std::filesystem::absolute(xmf, ec).lexically_normal().parent_path();
  std::filesystem::path rel = a.lexically_relative(b);
  if (rel.empty()) rel = a;
  return rel.generic_string();
}

/// XML comments must not contain "--".
std::string commentSafe(std::string text) {
  for (std::size_t at = text.find("--"); at != std::string::npos; at = text.find("--", at)) text.replace(at, 2, "- ");
  return text;
}

/// One Uniform particle grid at `indent`; with `series` it carries its Time and a "position" attribute.
std::string particleGrid(const XdmfFrame& f, const std::filesystem::path& xmf, bool series, std::string_view indent) {
  const std::string h5 = xmlEscape(relativeName(f.h5, xmf));
  const std::string in(indent);
  const auto item = [&](std::string_view dims, std::string_view type, int precision, std::string_view path) {
    return fmt::format(
        "{}    <DataItem Dimensions=\"{}\" NumberType=\"{}\" Precision=\"{}\" Format=\"HDF\">{}:{}</DataItem>\n", in,
        dims, type, precision, h5, path);
  };
  const std::string vector = fmt::format("{} 3", f.count);
  const std::string scalar = fmt::format("{}", f.count);
  const auto attribute = [&](std::string_view name, int components, std::string_view type, int precision,
                             std::string_view path) {
    std::string s = fmt::format("{}  <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"Node\">\n", in,
                                xmlEscape(name), components == 3 ? "Vector" : "Scalar");
    s += item(components == 3 ? vector : scalar, type, precision, path);
    s += fmt::format("{}  </Attribute>\n", in);
    return s;
  };

  std::string xml = fmt::format("{}<Grid Name=\"particles\" GridType=\"Uniform\">\n", in);
  if (series) xml += fmt::format("{}  <Time Value=\"{:.17g}\"/>\n", in, f.time);
  xml += fmt::format("{}  <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{}\" NodesPerElement=\"1\">\n", in,
                     f.count);
  xml += item(fmt::format("{} 1", f.count), "Int", 4, "/xdmf/polyvertex");
  xml += fmt::format("{}  </Topology>\n", in);
  xml += fmt::format("{}  <Geometry GeometryType=\"XYZ\">\n", in);
  xml += item(vector, "Float", 8, "/particles/position");
  xml += fmt::format("{}  </Geometry>\n", in);
  xml += attribute("radius", 1, "Float", 8, "/particles/radius");
  xml += attribute("id", 1, "Int", 4, "/particles/id");
  if (series) xml += attribute("position", 3, "Float", 8, "/particles/position");
  if (f.velocity) xml += attribute("velocity", 3, "Float", 8, "/particles/velocity");
  if (f.angularVelocity) xml += attribute("angular_velocity", 3, "Float", 8, "/particles/angular_velocity");
  for (const auto& [name, components] : f.arrays) {
    xml += attribute(name, components, "Float", 8, "/particles/" + name);
  }
  xml += fmt::format("{}</Grid>\n", in);
  return xml;
}

/// The box [0, L] as its 12 edges: 8 corners inline and a Polyline topology of 2-node segments.
std::string boxGrid(double time, const Eigen::Vector3d& l, std::string_view indent) {
  const std::string in(indent);
  std::string corners;
  for (int c = 0; c < 8; ++c) {
    corners += fmt::format("{}{:.17g} {:.17g} {:.17g}", c == 0 ? "" : " ", (c & 1) ? l[0] : 0.0, (c & 2) ? l[1] : 0.0,
                           (c & 4) ? l[2] : 0.0);
  }
  // Corner c has bit k set when it sits at L along axis k; an edge joins corners differing in one bit.
  constexpr char kEdges[] = "0 1 2 3 4 5 6 7 0 2 1 3 4 6 5 7 0 4 1 5 2 6 3 7";
  std::string xml = fmt::format("{}<Grid Name=\"box\" GridType=\"Uniform\">\n", in);
  xml += fmt::format("{}  <Time Value=\"{:.17g}\"/>\n", in, time);
  xml += fmt::format("{}  <Topology TopologyType=\"Polyline\" NumberOfElements=\"12\" NodesPerElement=\"2\">\n", in);
  xml += fmt::format(
      "{}    <DataItem Dimensions=\"12 2\" NumberType=\"Int\" Precision=\"4\" Format=\"XML\">{}</DataItem>\n", in,
      kEdges);
  xml += fmt::format("{}  </Topology>\n", in);
  xml += fmt::format("{}  <Geometry GeometryType=\"XYZ\">\n", in);
  xml += fmt::format(
      "{}    <DataItem Dimensions=\"8 3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">{}</DataItem>\n", in,
      corners);
  xml += fmt::format("{}  </Geometry>\n", in);
  xml += fmt::format("{}</Grid>\n", in);
  return xml;
}

/// One Uniform contact grid at `indent` (see xdmfContactXml); with `series` it carries its Time and the
/// line ends as a node attribute "position".
std::string contactGrid(const XdmfContactFrame& f, const std::filesystem::path& xmf, bool series,
                        std::string_view indent) {
  const std::string h5 = xmlEscape(relativeName(f.h5, xmf));
  const std::string in(indent);
  const auto item = [&](std::string_view dims, std::string_view type, std::string_view path) {
    return fmt::format(
        "{}    <DataItem Dimensions=\"{}\" NumberType=\"{}\" Precision=\"{}\" Format=\"HDF\">{}:{}</DataItem>\n", in,
        dims, type, type == "Int" ? 4 : 8, h5, path);
  };
  const auto attribute = [&](std::string_view name, int components, std::string_view type, std::string_view center,
                             Index rows, std::string_view path) {
    std::string s = fmt::format("{}  <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"{}\">\n", in, name,
                                components == 3 ? "Vector" : "Scalar", center);
    s += item(components == 3 ? fmt::format("{} 3", rows) : fmt::format("{}", rows), type, path);
    s += fmt::format("{}  </Attribute>\n", in);
    return s;
  };
  const Index m = f.count;
  std::string xml = fmt::format("{}<Grid Name=\"contacts\" GridType=\"Uniform\">\n", in);
  if (series) xml += fmt::format("{}  <Time Value=\"{:.17g}\"/>\n", in, f.time);
  xml += fmt::format("{}  <Topology TopologyType=\"Polyline\" NumberOfElements=\"{}\" NodesPerElement=\"2\">\n", in, m);
  xml += item(fmt::format("{} 2", m), "Int", "/xdmf/lines");
  xml += fmt::format("{}  </Topology>\n", in);
  xml += fmt::format("{}  <Geometry GeometryType=\"XYZ\">\n", in);
  xml += item(fmt::format("{} 3", 2 * m), "Float", "/xdmf/points");
  xml += fmt::format("{}  </Geometry>\n", in);
  xml += attribute("fn", 1, "Float", "Cell", m, "/contacts/fn");
  xml += attribute("normal_force", 3, "Float", "Cell", m, "/contacts/normal_force");
  if (f.tangential) xml += attribute("tangential_force", 3, "Float", "Cell", m, "/contacts/tangential_force");
  xml += attribute("overlap", 1, "Float", "Cell", m, "/contacts/overlap");
  xml += attribute("branch", 3, "Float", "Cell", m, "/contacts/branch");
  xml += attribute("id_i", 1, "Int", "Cell", m, "/contacts/id_i");
  xml += attribute("id_j", 1, "Int", "Cell", m, "/contacts/id_j");
  if (series) xml += attribute("position", 3, "Float", "Node", 2 * m, "/xdmf/points");
  xml += fmt::format("{}</Grid>\n", in);
  return xml;
}

constexpr char kHead[] = "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n";

}  // namespace

XdmfFrame xdmfFrameOf(const std::filesystem::path& h5, const ParticleData& data) {
  XdmfFrame f;
  f.h5 = h5;
  f.time = data.time;
  f.count = data.count();
  f.boxLengths = data.box.lengths();
  f.velocity = data.velocity.has_value();
  f.angularVelocity = data.angularVelocity.has_value();
  for (const ParticleArray& a : data.arrays) f.arrays.emplace_back(a.name, static_cast<int>(a.values.rows()));
  return f;
}

std::string xdmfSnapshotXml(const XdmfFrame& frame, const std::filesystem::path& xmf) {
  std::string xml = kHead;
  xml += fmt::format("<!-- polydem snapshot: time = {:.17g} s; parameters in {}:/parameters -->\n", frame.time,
                     commentSafe(relativeName(frame.h5, xmf)));
  xml += "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  xml += particleGrid(frame, xmf, false, "    ");
  xml += "  </Domain>\n</Xdmf>\n";
  return xml;
}

std::string xdmfSeriesXml(std::span<const XdmfFrame> frames, const std::filesystem::path& xmf) {
  std::string xml = kHead;
  xml += fmt::format("<!-- polydem snapshot series: {} frames -->\n", frames.size());
  xml += "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  xml += "    <Grid Name=\"box\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const XdmfFrame& f : frames) xml += boxGrid(f.time, f.boxLengths, "      ");
  xml += "    </Grid>\n";
  xml += "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const XdmfFrame& f : frames) xml += particleGrid(f, xmf, true, "      ");
  xml += "    </Grid>\n";
  xml += "  </Domain>\n</Xdmf>\n";
  return xml;
}

void writeXdmfSeries(const std::filesystem::path& xmf, std::span<const XdmfFrame> frames) {
  writeFileAtomically(xmf, xdmfSeriesXml(frames, xmf));
}

XdmfContactFrame xdmfContactFrameOf(const std::filesystem::path& h5, const ContactData& data) {
  XdmfContactFrame f;
  f.h5 = h5;
  f.time = data.time;
  f.count = data.count();
  f.boxLengths = data.box.lengths();
  f.tangential = data.tangentialForce.has_value();
  return f;
}

std::string xdmfContactXml(const XdmfContactFrame& frame, const std::filesystem::path& xmf) {
  std::string xml = kHead;
  xml += fmt::format("<!-- polydem contacts: {} pairs, time = {:.17g} s; parameters in {}:/parameters -->\n",
                     frame.count, frame.time, commentSafe(relativeName(frame.h5, xmf)));
  xml += "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  xml += contactGrid(frame, xmf, false, "    ");
  xml += "  </Domain>\n</Xdmf>\n";
  return xml;
}

std::string xdmfContactSeriesXml(std::span<const XdmfContactFrame> frames, const std::filesystem::path& xmf) {
  std::string xml = kHead;
  xml += fmt::format("<!-- polydem contact series: {} frames -->\n", frames.size());
  xml += "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  xml += "    <Grid Name=\"box\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const XdmfContactFrame& f : frames) xml += boxGrid(f.time, f.boxLengths, "      ");
  xml += "    </Grid>\n";
  xml += "    <Grid Name=\"contacts\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const XdmfContactFrame& f : frames) xml += contactGrid(f, xmf, true, "      ");
  xml += "    </Grid>\n";
  xml += "  </Domain>\n</Xdmf>\n";
  return xml;
}

void writeXdmfContactSeries(const std::filesystem::path& xmf, std::span<const XdmfContactFrame> frames) {
  writeFileAtomically(xmf, xdmfContactSeriesXml(frames, xmf));
}

std::filesystem::path seriesPathFor(const std::string& snapshotPattern) {
  std::string name = snapshotPattern;
  const std::size_t at = name.find("{step}");
  std::filesystem::path path;
  if (at != std::string::npos) {
    name.replace(at, 6, "series");
    path = name;
  } else {
    path = name;
    path = path.parent_path() / (path.stem().string() + "_series");
  }
  path.replace_extension(".xmf");
  return path;
}

}  // namespace polydem::io
