// LAMMPS native text dumps, see lammps_dump.hpp.
#include "core/io/lammps_dump.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <unordered_set>

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

/// The column names of a 3-component array: LAMMPS's own for the arrays it knows.
std::array<std::string, 3> vectorColumns(const std::string& name) {
  if (name == "force") return {"fx", "fy", "fz"};
  if (name == "torque") return {"tqx", "tqy", "tqz"};
  if (name == "image") return {"ix", "iy", "iz"};
  if (name == "angular_velocity") return {"omegax", "omegay", "omegaz"};
  return {name + "_x", name + "_y", name + "_z"};
}

/// The array a column belongs to and its component, for columns the reader has no fixed place for.
std::pair<std::string, int> arrayOfColumn(const std::string& column) {
  for (const char* name : {"force", "torque", "image"}) {
    const auto c = vectorColumns(name);
    for (int k = 0; k < 3; ++k) {
      if (column == c[std::size_t(k)]) return {name, k};
    }
  }
  if (column.size() > 2 && column[column.size() - 2] == '_') {
    const char last = column.back();
    if (last >= 'x' && last <= 'z') return {column.substr(0, column.size() - 2), last - 'x'};
  }
  return {column, -1};
}

}  // namespace

bool isLammpsDumpPath(const std::filesystem::path& file) {
  const std::string name = file.filename().string();
  const std::string ext = file.extension().string();
  return ext == ".dump" || ext == ".lammpstrj" || name.rfind("dump.", 0) == 0;
}

void writeLammpsDump(const std::filesystem::path& file, std::span<const ParticleData> frames) {
  std::string out;
  for (const ParticleData& data : frames) {
    requireConsistentSizes(data);
    const Index n = data.count();
    long long step = 0;
    if (const auto it = data.attributes.find("step"); it != data.attributes.end()) {
      if (const auto value = parseFiniteDouble(it->second)) step = std::llround(*value);
    }
    const ParticleArray* type = nullptr;
    for (const ParticleArray& a : data.arrays) {
      if (a.name == "type") type = &a;
    }
    // TIME before TIMESTEP: read_dump of LAMMPS 29 Sep 2021 accepts it there but refuses the file with it
    // after TIMESTEP (checked with Debian's lmp).
    out += fmt::format("ITEM: TIME\n{:.17g}\nITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{}\n", data.time, step, n);
    const auto bc = [&](int k) { return data.box.periodic(k) ? "pp" : "ff"; };
    out += fmt::format("ITEM: BOX BOUNDS {} {} {}\n", bc(0), bc(1), bc(2));
    for (int k = 0; k < 3; ++k) out += fmt::format("0 {:.17g}\n", data.box.length(k));
    out += "ITEM: ATOMS id type radius x y z";
    if (data.velocity) out += " vx vy vz";
    if (data.angularVelocity) out += " omegax omegay omegaz";
    for (const ParticleArray& a : data.arrays) {
      if (&a == type) continue;
      if (a.values.rows() == 1) {
        out += " " + a.name;
      } else {
        for (const std::string& c : vectorColumns(a.name)) out += " " + c;
      }
    }
    out += '\n';
    for (Index i = 0; i < n; ++i) {
      out += fmt::format("{} {} {:.17g} {:.17g} {:.17g} {:.17g}", data.id[std::size_t(i)] + 1LL,
                         type ? std::llround(type->values(0, i)) : 1LL, data.radius[i], data.position(0, i),
                         data.position(1, i), data.position(2, i));
      if (data.velocity) {
        out += fmt::format(" {:.17g} {:.17g} {:.17g}", (*data.velocity)(0, i), (*data.velocity)(1, i),
                           (*data.velocity)(2, i));
      }
      if (data.angularVelocity) {
        out += fmt::format(" {:.17g} {:.17g} {:.17g}", (*data.angularVelocity)(0, i), (*data.angularVelocity)(1, i),
                           (*data.angularVelocity)(2, i));
      }
      for (const ParticleArray& a : data.arrays) {
        if (&a == type) continue;
        for (Eigen::Index k = 0; k < a.values.rows(); ++k) out += fmt::format(" {:.17g}", a.values(k, i));
      }
      out += '\n';
    }
  }
  writeFileAtomically(file, out);
}

std::vector<ParticleData> readLammpsDump(const std::filesystem::path& file) {
  const Lines lines(file);
  std::vector<ParticleData> frames;
  std::size_t i = 0;
  const auto next = [&](std::string_view expected) -> std::size_t {
    if (i >= lines.text.size()) {
      lines.fail(lines.text.size(), fmt::format("the file ends where '{}' was expected", expected));
    }
    return ++i;  // the 1-based number of the line at i - 1
  };
  const auto expectItem = [&](std::string_view item) {
    const std::size_t ln = next(item);
    const std::string& line = lines.text[ln - 1];
    if (line.rfind(item, 0) != 0) lines.fail(ln, fmt::format("expected '{}', got '{}'", item, line));
    return ln;
  };
  while (i < lines.text.size()) {
    if (words(lines.text[i]).empty()) {
      ++i;
      continue;
    }
    ParticleData data;
    std::size_t ln = next("ITEM: TIME or ITEM: TIMESTEP");
    bool haveTime = false;
    const auto readTime = [&]() {
      ln = next("the time");
      const auto t = words(lines.text[ln - 1]);
      if (t.size() != 1) lines.fail(ln, "expected one time value");
      data.time = number(lines, ln, t[0], "time");
      haveTime = true;
    };
    if (lines.text[ln - 1].rfind("ITEM: TIME", 0) == 0 && lines.text[ln - 1].rfind("ITEM: TIMESTEP", 0) != 0) {
      readTime();
      ln = expectItem("ITEM: TIMESTEP");
    } else if (lines.text[ln - 1].rfind("ITEM: TIMESTEP", 0) != 0) {
      lines.fail(ln, fmt::format("expected 'ITEM: TIMESTEP', got '{}'", lines.text[ln - 1]));
    }
    ln = next("the timestep");
    const auto stepWords = words(lines.text[ln - 1]);
    if (stepWords.size() != 1) lines.fail(ln, "expected one timestep number");
    data.attributes["step"] = std::to_string(integer(lines, ln, stepWords[0], "timestep"));
    ln = next("ITEM: NUMBER OF ATOMS");
    if (!haveTime && lines.text[ln - 1].rfind("ITEM: TIME", 0) == 0 &&
        lines.text[ln - 1].rfind("ITEM: TIMESTEP", 0) != 0) {
      readTime();
      ln = expectItem("ITEM: NUMBER OF ATOMS");
    } else if (lines.text[ln - 1].rfind("ITEM: NUMBER OF ATOMS", 0) != 0) {
      lines.fail(ln, fmt::format("expected 'ITEM: NUMBER OF ATOMS', got '{}'", lines.text[ln - 1]));
    }
    ln = next("the number of atoms");
    const auto countWords = words(lines.text[ln - 1]);
    if (countWords.size() != 1) lines.fail(ln, "expected one atom count");
    const long long count = integer(lines, ln, countWords[0], "number of atoms");
    if (count < 0 || count > std::numeric_limits<Index>::max()) {
      lines.fail(ln, fmt::format("number of atoms {} is outside [0, {}]", count, std::numeric_limits<Index>::max()));
    }
    const Index n = static_cast<Index>(count);
    ln = expectItem("ITEM: BOX BOUNDS");
    const auto boxWords = words(lines.text[ln - 1]);
    if (boxWords.size() != 6) {
      lines.fail(ln,
                 "expected 'ITEM: BOX BOUNDS' and three boundary pairs (pp, ff, ...); a tilted box (xy xz yz) "
                 "is not supported");
    }
    std::array<Boundary, 3> boundaries{};
    for (int k = 0; k < 3; ++k) {
      const std::string_view b = boxWords[std::size_t(3 + k)];
      if (b.size() != 2)
        lines.fail(ln, fmt::format("boundary '{}' along {}: expected two letters such as pp or ff", b, kAxis[k]));
      boundaries[std::size_t(k)] = b == "pp" ? Boundary::Periodic : Boundary::Wall;
    }
    Eigen::Vector3d lo;
    Eigen::Vector3d length;
    for (int k = 0; k < 3; ++k) {
      ln = next("a box bounds line");
      const auto w = words(lines.text[ln - 1]);
      if (w.size() != 2)
        lines.fail(ln, fmt::format("box bounds along {}: expected 'lo hi', got {} words", kAxis[k], w.size()));
      lo[k] = number(lines, ln, w[0], fmt::format("{}lo", kAxis[k]));
      const double hi = number(lines, ln, w[1], fmt::format("{}hi", kAxis[k]));
      if (!(hi > lo[k])) lines.fail(ln, fmt::format("{}hi = {} must exceed {}lo = {}", kAxis[k], hi, kAxis[k], lo[k]));
      length[k] = hi - lo[k];
    }
    data.box = Box(length, boundaries);
    ln = expectItem("ITEM: ATOMS");
    const auto header = words(lines.text[ln - 1]);
    std::vector<std::string> columns;
    for (std::size_t c = 2; c < header.size(); ++c) columns.emplace_back(header[c]);
    std::map<std::string, std::size_t> where;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (!where.emplace(columns[c], c).second) lines.fail(ln, fmt::format("column '{}' appears twice", columns[c]));
    }
    const auto column = [&](const char* name) -> std::optional<std::size_t> {
      const auto it = where.find(name);
      return it == where.end() ? std::nullopt : std::optional(it->second);
    };
    const auto id = column("id");
    const std::array<std::optional<std::size_t>, 3> x = {column("x"), column("y"), column("z")};
    const auto radius = column("radius");
    const auto diameter = column("diameter");
    if (!id || !x[0] || !x[1] || !x[2] || !(radius || diameter)) {
      lines.fail(ln, "the ATOMS columns need id, x, y, z and radius or diameter");
    }
    const std::array<std::optional<std::size_t>, 3> v = {column("vx"), column("vy"), column("vz")};
    const std::array<std::optional<std::size_t>, 3> w = {column("omegax"), column("omegay"), column("omegaz")};
    const bool hasV = v[0] && v[1] && v[2];
    const bool hasW = w[0] && w[1] && w[2];
    std::unordered_set<std::size_t> placed = {*id, *x[0], *x[1], *x[2], radius ? *radius : *diameter};
    if (hasV) placed.insert({*v[0], *v[1], *v[2]});
    if (hasW) placed.insert({*w[0], *w[1], *w[2]});
    // Every other column becomes (a component of) an array.
    std::map<std::string, std::array<std::optional<std::size_t>, 3>> vectors;
    std::vector<std::pair<std::string, std::size_t>> scalars;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (placed.count(c) != 0) continue;
      const auto [name, k] = arrayOfColumn(columns[c]);
      if (k >= 0) {
        vectors[name][std::size_t(k)] = c;
      } else {
        scalars.emplace_back(name, c);
      }
    }
    for (auto it = vectors.begin(); it != vectors.end();) {  // incomplete triplets are scalar columns
      if (it->second[0] && it->second[1] && it->second[2]) {
        ++it;
        continue;
      }
      for (const auto& c : it->second) {
        if (c) scalars.emplace_back(columns[*c], *c);
      }
      it = vectors.erase(it);
    }

    data.position.resize(3, n);
    data.radius.resize(n);
    data.id.resize(std::size_t(n));
    if (hasV) data.velocity = Eigen::Matrix3Xd(3, n);
    if (hasW) data.angularVelocity = Eigen::Matrix3Xd(3, n);
    std::vector<ParticleArray> arrays;
    for (const auto& [name, c] : scalars) arrays.push_back({name, Eigen::MatrixXd(1, n)});
    for (const auto& [name, c] : vectors) arrays.push_back({name, Eigen::MatrixXd(3, n)});
    std::unordered_set<long long> ids;
    for (Index a = 0; a < n; ++a) {
      ln = next("an atom line");
      const auto f = words(lines.text[ln - 1]);
      if (f.size() != columns.size()) {
        lines.fail(ln,
                   fmt::format("expected {} columns ({}), got {}", columns.size(), fmt::join(columns, " "), f.size()));
      }
      const long long atomId = integer(lines, ln, f[*id], "id");
      if (atomId < 1 || atomId > std::numeric_limits<Index>::max()) {
        lines.fail(ln, fmt::format("id {} is outside [1, {}]", atomId, std::numeric_limits<Index>::max()));
      }
      if (!ids.insert(atomId).second) lines.fail(ln, fmt::format("id {} appears twice in this frame", atomId));
      data.id[std::size_t(a)] = static_cast<Index>(atomId - 1);
      const double r =
          radius ? number(lines, ln, f[*radius], "radius") : 0.5 * number(lines, ln, f[*diameter], "diameter");
      if (!(r > 0.0)) lines.fail(ln, fmt::format("radius must be positive, got {}", r));
      data.radius[a] = r;
      for (int k = 0; k < 3; ++k) {
        const double xk = number(lines, ln, f[*x[std::size_t(k)]], std::string(1, kAxis[k])) - lo[k];
        if (!data.box.periodic(k) && !(xk >= 0.0 && xk <= length[k])) {
          lines.fail(ln, fmt::format("{} = {} is outside the walled box along {}", kAxis[k], xk + lo[k], kAxis[k]));
        }
        data.position(k, a) = xk;
        if (hasV) (*data.velocity)(k, a) = number(lines, ln, f[*v[std::size_t(k)]], columns[*v[std::size_t(k)]]);
        if (hasW) (*data.angularVelocity)(k, a) = number(lines, ln, f[*w[std::size_t(k)]], columns[*w[std::size_t(k)]]);
      }
      data.position.col(a) = data.box.wrap(data.position.col(a));
      std::size_t slot = 0;
      for (const auto& [name, c] : scalars) arrays[slot++].values(0, a) = number(lines, ln, f[c], columns[c]);
      for (const auto& [name, c] : vectors) {
        for (int k = 0; k < 3; ++k)
          arrays[slot].values(k, a) = number(lines, ln, f[*c[std::size_t(k)]], columns[*c[std::size_t(k)]]);
        ++slot;
      }
    }
    // Types all 1 are the default, not information.
    for (auto it = arrays.begin(); it != arrays.end(); ++it) {
      if (it->name == "type" && (n == 0 || (it->values.array() == 1.0).all())) {
        arrays.erase(it);
        break;
      }
    }
    data.arrays = std::move(arrays);
    try {
      requireConsistentSizes(data);
    } catch (const ConfigError& e) {
      lines.fail(ln, e.what());
    }
    frames.push_back(std::move(data));
  }
  if (frames.empty()) lines.fail(0, "no frame (expected 'ITEM: TIMESTEP')");
  return frames;
}

}  // namespace polydem::io
