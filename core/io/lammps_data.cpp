// LAMMPS data files, atom_style sphere, see lammps_data.hpp.
#include "core/io/lammps_data.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <unordered_map>

#include "core/errors.hpp"
#include "core/io/attributes.hpp"
#include "core/io/lammps_text.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::io {

namespace {

using lammps::integer;
using lammps::Lines;
using lammps::number;
using lammps::words;

constexpr char kAxis[] = "xyz";

bool isSection(std::string_view word) {
  for (const char* s : {"Atoms",
                        "Velocities",
                        "Masses",
                        "Ellipsoids",
                        "Lines",
                        "Triangles",
                        "Bodies",
                        "Bonds",
                        "Angles",
                        "Dihedrals",
                        "Impropers",
                        "Pair",
                        "PairIJ",
                        "Bond",
                        "Angle",
                        "Dihedral",
                        "Improper",
                        "BondBond",
                        "BondAngle",
                        "MiddleBondTorsion",
                        "EndBondTorsion",
                        "AngleTorsion",
                        "AngleAngleTorsion",
                        "BondBond13",
                        "AngleAngle"}) {
    if (word == s) return true;
  }
  return false;
}

const ParticleArray* findArray(const ParticleData& data, std::string_view name) {
  for (const ParticleArray& a : data.arrays) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

}  // namespace

bool isLammpsDataPath(const std::filesystem::path& file) {
  const std::string name = file.filename().string();
  const std::string ext = file.extension().string();
  return ext == ".data" || ext == ".lmp" || name.rfind("data.", 0) == 0;
}

ParticleData readLammpsData(const std::filesystem::path& file, std::array<Boundary, 3> boundaries) {
  const Lines lines(file);
  if (lines.text.empty()) lines.fail(0, "empty file (a LAMMPS data file starts with a title line)");
  std::optional<long long> atoms;
  std::optional<long long> types;
  std::array<std::optional<std::pair<double, double>>, 3> bounds;
  std::size_t i = 1;  // the title line (line 1) is free text
  // Header: counts and box until the first section name.
  for (; i < lines.text.size(); ++i) {
    const std::size_t ln = i + 1;
    const auto w = words(lines.text[i]);
    if (w.empty()) continue;
    if (isSection(w[0])) break;
    if (w.size() == 2 && w[1] == "atoms") {
      atoms = integer(lines, ln, w[0], "atom count");
      if (*atoms < 0 || *atoms > std::numeric_limits<Index>::max()) {
        lines.fail(ln, fmt::format("atom count {} is outside [0, {}]", *atoms, std::numeric_limits<Index>::max()));
      }
    } else if (w.size() == 3 && w[1] == "atom" && w[2] == "types") {
      types = integer(lines, ln, w[0], "atom type count");
      if (*types < 1) lines.fail(ln, fmt::format("atom type count must be at least 1, got {}", *types));
    } else if (w.size() == 4 && w[3].size() == 3 && w[2].size() == 3 && w[2][1] == 'l' && w[2][2] == 'o' &&
               w[3][1] == 'h' && w[3][2] == 'i' && w[2][0] == w[3][0] && w[2][0] >= 'x' && w[2][0] <= 'z') {
      const int k = w[2][0] - 'x';
      const double lo = number(lines, ln, w[0], fmt::format("{}lo", kAxis[k]));
      const double hi = number(lines, ln, w[1], fmt::format("{}hi", kAxis[k]));
      if (!(hi > lo)) lines.fail(ln, fmt::format("{}hi = {} must exceed {}lo = {}", kAxis[k], hi, kAxis[k], lo));
      bounds[std::size_t(k)] = std::pair{lo, hi};
    } else if (w.size() == 6 && w[3] == "xy" && w[4] == "xz" && w[5] == "yz") {
      lines.fail(ln, "a tilted (triclinic) box: polydem boxes are orthogonal; write the data with an orthogonal box");
    } else if ((w.size() == 2 || (w.size() == 3 && w[2] == "types")) &&
               (w[1] == "bonds" || w[1] == "angles" || w[1] == "dihedrals" || w[1] == "impropers" ||
                w[1] == "ellipsoids" || w[1] == "lines" || w[1] == "triangles" || w[1] == "bodies" || w[1] == "bond" ||
                w[1] == "angle" || w[1] == "dihedral" || w[1] == "improper")) {
      if (integer(lines, ln, w[0], std::string(w[1])) != 0) {
        lines.fail(ln, fmt::format("'{}': polydem reads spheres only (atom_style sphere, no topology)", lines.text[i]));
      }
    } else {
      lines.fail(ln, fmt::format("unknown header line '{}'", lines.text[i]));
    }
  }
  if (!atoms) lines.fail(0, "the header has no 'N atoms' line");
  for (int k = 0; k < 3; ++k) {
    if (!bounds[std::size_t(k)]) {
      lines.fail(0, fmt::format("the header has no '{0}lo {0}hi' line", kAxis[k]));
    }
  }
  const long long nTypes = types.value_or(1);
  const Index n = static_cast<Index>(*atoms);
  Eigen::Vector3d lo;
  Eigen::Vector3d length;
  for (int k = 0; k < 3; ++k) {
    lo[k] = bounds[std::size_t(k)]->first;
    length[k] = bounds[std::size_t(k)]->second - lo[k];
  }

  ParticleData data;
  data.box = Box(length, boundaries);
  data.position.resize(3, n);
  data.radius.resize(n);
  data.id.resize(std::size_t(n));
  Eigen::MatrixXd type(1, n);
  Eigen::MatrixXd density(1, n);
  Eigen::MatrixXd image = Eigen::MatrixXd::Zero(3, n);
  bool haveImages = false;
  bool haveAtoms = false;
  std::unordered_map<long long, Index> slotOf;

  // Sections: a name line, then (after blank lines) one line per entry.
  while (i < lines.text.size()) {
    const std::size_t nameLine = i + 1;
    const auto w = words(lines.text[i]);
    if (w.empty()) {
      ++i;
      continue;
    }
    const std::string section(w[0]);
    if (!isSection(section) || w.size() != 1)
      lines.fail(nameLine, fmt::format("expected a section name, got '{}'", lines.text[i]));
    long long entries = 0;
    if (section == "Atoms") {
      const std::string& full = lines.text[i];
      const std::size_t hash = full.find('#');
      if (hash != std::string::npos) {
        const auto style = words(std::string_view(full).substr(hash + 1));
        if (!style.empty() && style[0] != "sphere") {
          lines.fail(nameLine, fmt::format("Atoms section of atom_style '{}': polydem reads atom_style sphere "
                                           "(id type diameter density x y z)",
                                           style[0]));
        }
      }
      if (haveAtoms) lines.fail(nameLine, "a second Atoms section");
      haveAtoms = true;
      entries = *atoms;
    } else if (section == "Velocities") {
      if (!haveAtoms) lines.fail(nameLine, "Velocities before Atoms");
      if (data.velocity) lines.fail(nameLine, "a second Velocities section");
      data.velocity = Eigen::Matrix3Xd::Zero(3, n);
      data.angularVelocity = Eigen::Matrix3Xd::Zero(3, n);
      entries = *atoms;
    } else if (section == "Masses") {
      entries = nTypes;
    } else {
      lines.fail(nameLine, fmt::format("section '{}': polydem reads Atoms, Velocities and Masses only", section));
    }
    ++i;
    std::vector<bool> seen(std::size_t(n), false);
    for (long long e = 0; e < entries; ++e) {
      while (i < lines.text.size() && words(lines.text[i]).empty()) ++i;
      if (i >= lines.text.size()) {
        lines.fail(lines.text.size(), fmt::format("{} section ends after {} of {} lines", section, e, entries));
      }
      const std::size_t ln = i + 1;
      const auto v = words(lines.text[i]);
      ++i;
      if (section == "Masses") {
        if (v.size() != 2) lines.fail(ln, fmt::format("Masses line: expected 'type mass', got {} words", v.size()));
        const long long t = integer(lines, ln, v[0], "atom type");
        if (t < 1 || t > nTypes) lines.fail(ln, fmt::format("atom type {} is outside [1, {}]", t, nTypes));
        number(lines, ln, v[1], "mass");
        continue;
      }
      if (section == "Atoms") {
        if (v.size() != 7 && v.size() != 10) {
          lines.fail(ln, fmt::format("Atoms line: expected 'id type diameter density x y z [ix iy iz]' (7 or 10 "
                                     "words), got {}",
                                     v.size()));
        }
        const long long id = integer(lines, ln, v[0], "atom id");
        if (id < 1 || id > std::numeric_limits<Index>::max()) {
          lines.fail(ln, fmt::format("atom id {} is outside [1, {}]", id, std::numeric_limits<Index>::max()));
        }
        const auto [it, fresh] = slotOf.emplace(id, static_cast<Index>(e));
        if (!fresh) lines.fail(ln, fmt::format("atom id {} appears twice", id));
        const long long t = integer(lines, ln, v[1], "atom type");
        if (t < 1 || t > nTypes) lines.fail(ln, fmt::format("atom type {} is outside [1, {}]", t, nTypes));
        const double d = number(lines, ln, v[2], "diameter");
        if (!(d > 0.0)) {
          lines.fail(ln, fmt::format("diameter must be positive, got {} (point particles are not spheres)", d));
        }
        const double rho = number(lines, ln, v[3], "density");
        if (!(rho > 0.0)) lines.fail(ln, fmt::format("density must be positive, got {}", rho));
        const Index s = static_cast<Index>(e);
        data.id[std::size_t(s)] = static_cast<Index>(id - 1);
        type(0, s) = static_cast<double>(t);
        data.radius[s] = 0.5 * d;
        density(0, s) = rho;
        for (int k = 0; k < 3; ++k) {
          double x = number(lines, ln, v[std::size_t(4 + k)], std::string(1, kAxis[k])) - lo[k];
          if (!data.box.periodic(k) && !(x >= 0.0 && x <= length[k])) {
            lines.fail(ln, fmt::format("{} = {} is outside the walled box [{}lo, {}hi]", kAxis[k], x + lo[k], kAxis[k],
                                       kAxis[k]));
          }
          data.position(k, s) = x;
        }
        data.position.col(s) = data.box.wrap(data.position.col(s));
        if (v.size() == 10) {
          haveImages = true;
          for (int k = 0; k < 3; ++k) {
            image(k, s) =
                static_cast<double>(integer(lines, ln, v[std::size_t(7 + k)], fmt::format("image flag i{}", kAxis[k])));
          }
        }
        continue;
      }
      // Velocities
      if (v.size() != 7) {
        lines.fail(ln, fmt::format("Velocities line: expected 'id vx vy vz wx wy wz' (7 words), got {}", v.size()));
      }
      const long long id = integer(lines, ln, v[0], "atom id");
      const auto found = slotOf.find(id);
      if (found == slotOf.end()) lines.fail(ln, fmt::format("atom id {} is not in the Atoms section", id));
      const Index s = found->second;
      if (seen[std::size_t(s)]) lines.fail(ln, fmt::format("atom id {} appears twice in Velocities", id));
      seen[std::size_t(s)] = true;
      for (int k = 0; k < 3; ++k) {
        (*data.velocity)(k, s) = number(lines, ln, v[std::size_t(1 + k)], fmt::format("v{}", kAxis[k]));
        (*data.angularVelocity)(k, s) = number(lines, ln, v[std::size_t(4 + k)], fmt::format("w{}", kAxis[k]));
      }
    }
  }
  if (!haveAtoms && n > 0) lines.fail(0, fmt::format("no Atoms section for the {} atoms of the header", n));
  if (n > 0 && (type.array() != 1.0).any()) data.arrays.push_back({"type", type});
  if (n > 0 && (density.array() != density(0, 0)).any()) {
    data.arrays.push_back({"density", density});
  } else if (n > 0) {
    data.attributes["density"] = fmt::format("{:.17g}", density(0, 0));
  }
  if (haveImages) data.arrays.push_back({"image", image});
  return data;
}

void writeLammpsData(const std::filesystem::path& file, const ParticleData& data) {
  requireConsistentSizes(data);
  const Index n = data.count();
  const ParticleArray* type = findArray(data, "type");
  const ParticleArray* density = findArray(data, "density");
  const ParticleArray* image = findArray(data, "image");
  double uniformDensity = 1.0;
  if (const auto it = data.attributes.find("density"); it != data.attributes.end()) {
    if (const auto value = parseFiniteDouble(it->second)) uniformDensity = *value;
  }
  long long nTypes = 1;
  if (type) nTypes = static_cast<long long>(std::llround(type->values.maxCoeff()));
  std::string out;
  out += fmt::format("LAMMPS data file (atom_style sphere) written by polydem, time = {:.17g} s\n\n", data.time);
  out += fmt::format("{} atoms\n{} atom types\n\n", n, std::max<long long>(nTypes, 1));
  for (int k = 0; k < 3; ++k) out += fmt::format("0 {:.17g} {}lo {}hi\n", data.box.length(k), kAxis[k], kAxis[k]);
  out += "\nAtoms # sphere\n\n";
  for (Index i = 0; i < n; ++i) {
    const Eigen::Vector3d x = data.box.wrap(data.position.col(i));
    out += fmt::format("{} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}", data.id[std::size_t(i)] + 1LL,
                       type ? std::llround(type->values(0, i)) : 1LL, 2.0 * data.radius[i],
                       density ? density->values(0, i) : uniformDensity, x[0], x[1], x[2]);
    if (image) {
      out += fmt::format(" {} {} {}", std::llround(image->values(0, i)), std::llround(image->values(1, i)),
                         std::llround(image->values(2, i)));
    }
    out += '\n';
  }
  if (data.velocity) {
    out += "\nVelocities\n\n";
    for (Index i = 0; i < n; ++i) {
      const Eigen::Vector3d w =
          data.angularVelocity ? Eigen::Vector3d(data.angularVelocity->col(i)) : Eigen::Vector3d::Zero();
      out += fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\n", data.id[std::size_t(i)] + 1LL,
                         (*data.velocity)(0, i), (*data.velocity)(1, i), (*data.velocity)(2, i), w[0], w[1], w[2]);
    }
  }
  writeFileAtomically(file, out);
}

}  // namespace polydem::io
