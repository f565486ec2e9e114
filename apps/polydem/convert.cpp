// polydem convert: particle files between plain text, HDF5 (+ XDMF), LAMMPS data and LAMMPS dump, and
// XDMF temporal series over a set of HDF5 snapshots. Formats by extension unless --from/--to say.
#include "apps/polydem/convert.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/lammps_data.hpp"
#include "core/io/lammps_dump.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "core/io/xdmf.hpp"

namespace polydem::app {

namespace {

struct ConvertOptions {
  std::vector<std::string> files;
  std::string from;
  std::string to;
  std::string series;
  std::string boundary = "periodic";
  std::optional<long long> frame;
};

std::string formatOf(const std::filesystem::path& file, const std::string& given) {
  if (!given.empty()) return given;
  if (io::isHdf5Path(file)) return "hdf5";
  if (io::isLammpsDumpPath(file)) return "lammps-dump";
  if (io::isLammpsDataPath(file)) return "lammps-data";
  return "text";
}

/// The frames of one input: one for every format but a dump, which may hold many.
std::vector<io::ParticleData> readFrames(const std::filesystem::path& file, const std::string& format,
                                         std::array<Boundary, 3> boundaries) {
  if (format == "hdf5") return {io::readSnapshot(file)};
  if (format == "lammps-data") return {io::readLammpsData(file, boundaries)};
  if (format == "lammps-dump") return io::readLammpsDump(file);
  return {io::readText(file, boundaries)};
}

void writeOne(const std::filesystem::path& file, const std::string& format, const io::ParticleData& data) {
  if (format == "hdf5") {
    io::writeSnapshot(file, data);
  } else if (format == "lammps-data") {
    io::writeLammpsData(file, data);
  } else {
    io::writeText(file, data);  // with the arrays as extra columns
  }
}

int runSeries(const ConvertOptions& opt) {
  const std::vector<io::XdmfFrame> frames =
      writeSeries(opt.series, std::vector<std::filesystem::path>(opt.files.begin(), opt.files.end()));
  fmt::print("wrote {}: {} frames, t = {:.6g} .. {:.6g} s\n", opt.series, frames.size(), frames.front().time,
             frames.back().time);
  return 0;
}

int runConvert(const ConvertOptions& opt) {
  if (!opt.series.empty()) return runSeries(opt);
  if (opt.files.size() < 2) throw ConfigError("convert: give IN OUT (or IN... OUT.dump for a multi-frame dump)");
  const std::filesystem::path out = opt.files.back();
  std::vector<std::filesystem::path> inputs(opt.files.begin(), opt.files.end() - 1);
  const std::string toFormat = formatOf(out, opt.to);
  if (inputs.size() > 1 && toFormat != "lammps-dump") {
    throw ConfigError(
        fmt::format("convert: {} inputs need a multi-frame output (a LAMMPS dump); '{}' holds one "
                    "configuration (for an XDMF series use --series OUT.xmf FILES...)",
                    inputs.size(), out.string()));
  }
  io::checkOutputPath(out, "OUT", inputs);
  if (toFormat == "hdf5") io::checkOutputPath(io::xdmfPath(out), "OUT (its XDMF sidecar)", inputs);
  const auto boundaries = parseBoundaries(opt.boundary);

  std::vector<io::ParticleData> frames;
  for (const auto& in : inputs) {
    std::vector<io::ParticleData> read = readFrames(in, formatOf(in, opt.from), boundaries);
    for (auto& f : read) frames.push_back(std::move(f));
  }
  if (toFormat == "lammps-dump") {
    if (opt.frame) throw ConfigError("--frame: selects one frame of a dump input; a dump output takes them all");
    io::writeLammpsDump(out, frames);
    fmt::print("wrote {}: {} frame(s), {} particles in the last\n", out.string(), frames.size(), frames.back().count());
    return 0;
  }
  std::size_t pick = frames.size() - 1;
  if (opt.frame) {
    if (*opt.frame < 0 || *opt.frame >= static_cast<long long>(frames.size())) {
      throw ConfigError(
          fmt::format("--frame {}: '{}' holds frames 0 .. {}", *opt.frame, inputs.front().string(), frames.size() - 1));
    }
    pick = static_cast<std::size_t>(*opt.frame);
  } else if (frames.size() > 1) {
    fmt::print("note: '{}' holds {} frames; converting the last (choose one with --frame K)\n", inputs.front().string(),
               frames.size());
  }
  writeOne(out, toFormat, frames[pick]);
  fmt::print("wrote {} ({}): {} particles\n", out.string(), toFormat, frames[pick].count());
  return 0;
}

}  // namespace

Runner addConvert(CLI::App& app) {
  auto opt = std::make_shared<ConvertOptions>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "convert particle files between text, HDF5 (.h5 + .xmf), LAMMPS data and LAMMPS dump; XDMF series");
  cmd->add_option("files", opt->files,
                  "IN OUT; several inputs with a dump output (one frame each); with --series: the HDF5 snapshots")
      ->required();
  const std::vector<std::string> formats = {"text", "hdf5", "lammps-data", "lammps-dump"};
  cmd->add_option("--from", opt->from,
                  "input format (default by extension: .h5/.hdf5 hdf5, .data/.lmp/data.* lammps-data, "
                  ".dump/.lammpstrj/dump.* lammps-dump, else text)")
      ->check(CLI::IsMember(formats));
  cmd->add_option("--to", opt->to, "output format (default by extension, as --from)")->check(CLI::IsMember(formats));
  cmd->add_option("--series", opt->series,
                  "write an XDMF temporal collection OUT.xmf over the HDF5 snapshots given as files (in that order)");
  cmd->add_option("--boundary", opt->boundary,
                  "boundaries for inputs that carry none (text without '# boundaries:', LAMMPS data)")
      ->check(boundaryNames())
      ->capture_default_str();
  cmd->add_option("--frame", opt->frame, "which frame of a multi-frame dump input to convert (0-based; default last)");
  return [opt]() { return runConvert(*opt); };
}

}  // namespace polydem::app
