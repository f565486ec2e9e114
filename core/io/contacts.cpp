// Contact files, see contacts.hpp. The CSV writer and the paths live here; the HDF5 writer and reader in
// hdf5_snapshot.cpp, beside the snapshot code whose HDF5 helpers they share.
#include "core/io/contacts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <iterator>
#include <string>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/particle_io.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::io {

namespace {

/// A one-line rendering of an attribute value for a CSV comment (line breaks become blanks).
std::string oneLine(std::string text) {
  std::replace_if(
      text.begin(), text.end(), [](char c) { return c == '\n' || c == '\r'; }, ' ');
  return text;
}

void writeContactsCsv(const std::filesystem::path& file, const ContactData& d) {
  const Index m = d.count();
  const bool tangential = d.tangentialForce.has_value();
  std::string text;
  auto out = std::back_inserter(text);
  // The column names come first, so numpy.genfromtxt(names=True) finds them; the comments after them are
  // skipped by it, by pandas.read_csv(comment="#") and by polydem.
  text += "id_i,id_j,overlap,fn,normal_force_x,normal_force_y,normal_force_z,";
  if (tangential) text += "tangential_force_x,tangential_force_y,tangential_force_z,";
  text += "branch_x,branch_y,branch_z,centre_x,centre_y,centre_z\n";
  fmt::format_to(out, "# polydem contacts: {} particle pairs in contact\n", m);
  fmt::format_to(out, "# time: {:.17g}\n", d.time);
  fmt::format_to(out, "# box: {:.17g} {:.17g} {:.17g}", d.box.length(0), d.box.length(1), d.box.length(2));
  for (int k = 0; k < 3; ++k) fmt::format_to(out, " {}", d.box.periodic(k) ? "periodic" : "wall");
  text += "\n";
  for (const auto& [key, value] : d.attributes) fmt::format_to(out, "# attribute: {} = {}\n", key, oneLine(value));
  text +=
      "# forces on i from j (on j: the negatives), N; fn > 0 repulsive; normal_force = fn n, n = -branch / |branch|\n"
      "# branch: centre of i to the nearest periodic image of the centre of j (m); centre: i's centre in the box\n";
  for (Index c = 0; c < m; ++c) {
    const Eigen::Vector3d fn = d.normalForceVector(c);
    fmt::format_to(out, "{},{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},", d.idI[std::size_t(c)], d.idJ[std::size_t(c)],
                   d.overlap[c], d.normalForce[c], fn[0], fn[1], fn[2]);
    if (tangential) {
      const auto ft = d.tangentialForce->col(c);
      fmt::format_to(out, "{:.17g},{:.17g},{:.17g},", ft[0], ft[1], ft[2]);
    }
    fmt::format_to(out, "{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", d.branch(0, c), d.branch(1, c),
                   d.branch(2, c), d.centre(0, c), d.centre(1, c), d.centre(2, c));
  }
  writeFileAtomically(file, text);
}

}  // namespace

void requireConsistentContacts(const ContactData& d) {
  const Eigen::Index m = d.overlap.size();
  auto mismatch = [&](const char* what, Eigen::Index got) {
    throw ConfigError(fmt::format("contact data: {} has {} entries but overlap has {}", what, got, m));
  };
  if (static_cast<Eigen::Index>(d.idI.size()) != m) mismatch("id_i", static_cast<Eigen::Index>(d.idI.size()));
  if (static_cast<Eigen::Index>(d.idJ.size()) != m) mismatch("id_j", static_cast<Eigen::Index>(d.idJ.size()));
  if (d.centre.cols() != m) mismatch("centre", d.centre.cols());
  if (d.branch.cols() != m) mismatch("branch", d.branch.cols());
  if (d.normalForce.size() != m) mismatch("fn", d.normalForce.size());
  if (d.tangentialForce && d.tangentialForce->cols() != m) mismatch("tangential_force", d.tangentialForce->cols());
  for (std::size_t c = 0; c < d.idI.size(); ++c) {
    if (!(d.idI[c] >= 0 && d.idI[c] < d.idJ[c])) {
      throw ConfigError(
          fmt::format("contact data: row {}: ids ({}, {}) must satisfy 0 <= id_i < id_j", c, d.idI[c], d.idJ[c]));
    }
  }
}

void writeContacts(const std::filesystem::path& file, const ContactData& data) {
  requireConsistentContacts(data);
  if (isHdf5Path(file)) {
    writeContactsHdf5(file, data);
  } else {
    writeContactsCsv(file, data);
  }
}

std::filesystem::path contactPathFor(const std::filesystem::path& snapshot) {
  const std::string extension = isHdf5Path(snapshot) ? snapshot.extension().string() : std::string(".csv");
  return snapshot.parent_path() / (snapshot.stem().string() + "_contacts" + extension);
}

std::filesystem::path contactXdmfPath(const std::filesystem::path& file) {
  std::filesystem::path sidecar = file;
  sidecar.replace_extension(".xmf");
  return sidecar;
}

std::filesystem::path contactSeriesPathFor(const std::string& snapshotPattern) {
  std::string name = snapshotPattern;
  const std::size_t at = name.find("{step}");
  std::filesystem::path path;
  if (at != std::string::npos) {
    name.replace(at, 6, "contacts_series");
    path = name;
  } else {
    path = name;
    path = path.parent_path() / (path.stem().string() + "_contacts_series");
  }
  path.replace_extension(".xmf");
  return path;
}

}  // namespace polydem::io
