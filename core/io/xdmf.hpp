#pragma once
// XDMF 3 descriptions of HDF5 snapshots (core/io/hdf5_snapshot.hpp), written so that ParaView's
// Xdmf3ReaderS, VisIt and meshio (5.x and 7.x, read() and xdmf.TimeSeriesReader) all open them.
//
// What each reader needs, and therefore what is written:
// - Polyvertex topology with explicit connectivity (the dataset /xdmf/polyvertex, N x 1 int32 0..N-1):
//   without it Xdmf3ReaderS makes 0 cells and meshio stops.
// - Sidecar of one snapshot (snap.h5 -> snap.xmf): exactly one Uniform grid holding only Topology,
//   Geometry and Attribute elements, because meshio.read() accepts one grid and rejects any other
//   element (Time, an Information without XML text). The time and the parameters stay in the HDF5 file;
//   the time is repeated in an XML comment for humans.
// - Series (GridType="Collection" CollectionType="Temporal", one Uniform grid per snapshot with its
//   Time): two temporal collections in one Domain, first the box (12 edges as a Polyline grid with NodesPerElement 2,
//   so a true cell outline shows without an Outline filter, box lengths per frame since a compression changes them),
//   last the particles. meshio's TimeSeriesReader takes the last collection and reads the mesh once, so every particle
//   frame also carries its positions as a node attribute "position".
//
// HDF5 paths are written relative to the directory of the .xmf file, so a directory of snapshots can be
// moved as a whole.
#include <Eigen/Core>
#include <filesystem>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/io/contacts.hpp"
#include "core/io/particle_data.hpp"

namespace polydem::io {

/// What an XDMF description needs to know about one snapshot file.
struct XdmfFrame {
  std::filesystem::path h5;                              ///< the HDF5 snapshot
  double time = 0.0;                                     ///< s
  Index count = 0;                                       ///< particles
  Eigen::Vector3d boxLengths = Eigen::Vector3d::Ones();  ///< m
  bool velocity = false;
  bool angularVelocity = false;
  std::vector<std::pair<std::string, int>> arrays;  ///< optional arrays: name, components (1 or 3)
};

/// The frame of `data` written to `h5` (the arrays it holds, its time, count and box).
XdmfFrame xdmfFrameOf(const std::filesystem::path& h5, const ParticleData& data);

/// The sidecar text of one snapshot (one Uniform grid, see above); HDF5 paths relative to `xmf`'s directory.
std::string xdmfSnapshotXml(const XdmfFrame& frame, const std::filesystem::path& xmf);

/// The temporal-collection text for `frames` in the given order (box collection, then particles).
std::string xdmfSeriesXml(std::span<const XdmfFrame> frames, const std::filesystem::path& xmf);

/// Write xdmfSeriesXml() to `xmf` atomically. Throws InputError if it cannot be written.
void writeXdmfSeries(const std::filesystem::path& xmf, std::span<const XdmfFrame> frames);

/// What an XDMF description needs to know about one contact file (core/io/contacts.hpp).
struct XdmfContactFrame {
  std::filesystem::path h5;                              ///< the HDF5 contact file
  double time = 0.0;                                     ///< s
  Index count = 0;                                       ///< contacts
  Eigen::Vector3d boxLengths = Eigen::Vector3d::Ones();  ///< m
  bool tangential = false;                               ///< holds /contacts/tangential_force
};

/// The frame of the contacts `data` written to `h5`.
XdmfContactFrame xdmfContactFrameOf(const std::filesystem::path& h5, const ContactData& data);

/// The sidecar text of one contact file: one Uniform grid of 2-node Polyline cells (one per contact, from
/// the centre of i to centre + branch) with the per-contact data as cell attributes.
std::string xdmfContactXml(const XdmfContactFrame& frame, const std::filesystem::path& xmf);

/// The temporal collection of contact files, as xdmfSeriesXml(): the box collection, then the contacts
/// (each frame also carries its line ends as a node attribute "position", for meshio's TimeSeriesReader).
std::string xdmfContactSeriesXml(std::span<const XdmfContactFrame> frames, const std::filesystem::path& xmf);

/// Write xdmfContactSeriesXml() to `xmf` atomically. Throws InputError if it cannot be written.
void writeXdmfContactSeries(const std::filesystem::path& xmf, std::span<const XdmfContactFrame> frames);

/// The series file that accompanies a snapshot pattern such as "out/snap_{step}.h5": "{step}" replaced
/// by "series" and the extension by .xmf ("out/snap_series.xmf"); without "{step}", "NAME_series.xmf".
std::filesystem::path seriesPathFor(const std::string& snapshotPattern);

}  // namespace polydem::io
