#pragma once
// polydem convert, the part the Python module shares: the checked XDMF series writer of --series.
#include <filesystem>
#include <vector>

#include "core/io/xdmf.hpp"

namespace polydem::app {

/// `convert --series OUT.xmf SNAPSHOTS...`: refuses inputs that are not HDF5 snapshots, an output that does not
/// end in .xmf or is an input's sidecar (ConfigError naming --series), reads each snapshot and writes the
/// temporal collection. Returns the frames written.
std::vector<io::XdmfFrame> writeSeries(const std::filesystem::path& out,
                                       const std::vector<std::filesystem::path>& inputs);

}  // namespace polydem::app
