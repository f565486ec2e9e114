// polydem convert --series: the checked XDMF series writer (shared with the Python module).
#include <fmt/format.h>

#include "apps/polydem/convert.hpp"
#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::app {

std::vector<io::XdmfFrame> writeSeries(const std::filesystem::path& out,
                                       const std::vector<std::filesystem::path>& inputs) {
  if (inputs.empty()) throw ConfigError("--series: give the HDF5 snapshots of the series after the output name");
  for (const auto& in : inputs) {
    if (!io::isHdf5Path(in)) {
      throw ConfigError(
          fmt::format("--series: '{}' is not an HDF5 snapshot (.h5/.hdf5); an XDMF series refers to "
                      "HDF5 datasets: convert it first (polydem convert {} NAME.h5)",
                      in.string(), in.string()));
    }
  }
  if (out.extension() != ".xmf")
    throw ConfigError(fmt::format("--series '{}': the series file must end in .xmf", out.string()));
  io::checkOutputPath(out, "--series", inputs);
  for (const auto& in : inputs) {
    if (io::samePath(out, io::xdmfPath(in))) {
      throw ConfigError(
          fmt::format("--series '{}' is the XDMF sidecar of '{}': choose another name", out.string(), in.string()));
    }
  }
  std::vector<io::XdmfFrame> frames;
  for (const auto& in : inputs) frames.push_back(io::xdmfFrameOf(in, io::readSnapshot(in)));
  io::writeXdmfSeries(out, frames);
  return frames;
}

}  // namespace polydem::app
