#pragma once
// Contact files: the particle pairs in contact in one snapshot, for force-chain analysis (issue 21).
// `polydem relax` writes one beside every snapshot when the scene sets output.contacts = true.
//
// One row per pair in contact (overlap > 0), id_i < id_j, rows sorted by (id_i, id_j). Forces act on i
// and come from j; the forces on j are their negatives. SI units.
//   id_i, id_j         stored particle ids, as in the snapshot's id column (/particles/id)
//   centre             centre of i wrapped into the box: the snapshot's position of id_i (m)
//   branch             from the centre of i to the centre of j, periodic-image aware: to the image of j
//                      nearest to i (minimum image), so |branch| = r_i + r_j - overlap (m)
//   overlap            r_i + r_j - |branch| > 0 (m)
//   fn                 the normal force, signed: > 0 repulsive, slightly < 0 at the end of a damped contact (N)
//   normal_force       fn n on i, n = -branch / |branch| the unit normal from j to i (N)
//   tangential_force   friction force on i, in the tangent plane (N); only for laws with friction
//
// Formats, by extension:
// - .h5/.hdf5: HDF5 plus an XDMF sidecar (contactXdmfPath(), NAME.xmf) that ParaView and meshio open as
//   line cells, one 2-node Polyline per contact from the centre of i to centre + branch (for a pair across
//   a periodic boundary the line goes to the image of j and sticks out of the box by up to r_j, so a
//   force chain stays continuous; the far end of the line is not the stored position of j). Layout:
//     /contacts/id_i, /contacts/id_j      M int32
//     /contacts/centre, branch, normal_force, tangential_force (optional)   M x 3 double
//     /contacts/overlap, /contacts/fn     M double
//     /xdmf/points   2M x 3 double: centre, centre + branch for each contact (the line ends)
//     /xdmf/lines    M x 2 int32: 2c, 2c + 1
//     /box/lengths (3 double), /box/periodic (3 int8), /parameters (string attributes), root attribute time
//   The per-contact datasets are XDMF cell attributes (Center="Cell"), so a line is coloured by its fn.
// - anything else: CSV, first the line of column names
//     id_i,id_j,overlap,fn,normal_force_x,normal_force_y,normal_force_z,
//     [tangential_force_x,tangential_force_y,tangential_force_z,]branch_x,branch_y,branch_z,
//     centre_x,centre_y,centre_z
//   then '#' comment lines (count, time, box, attributes, conventions), then one line per contact at full
//   precision (%.17g). numpy.genfromtxt(file, delimiter=",", names=True) and pandas.read_csv(file,
//   comment="#") read it as it is.
#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::io {

/// The contacts of one configuration (see above for the meaning of each field). M = count().
struct ContactData {
  Box box;
  double time = 0.0;                                ///< s
  std::map<std::string, std::string> attributes;    ///< free-form key -> value (step, law, snapshot file)
  std::vector<Index> idI, idJ;                      ///< M each, idI < idJ, sorted by (idI, idJ)
  Eigen::Matrix3Xd centre;                          ///< 3 x M, m
  Eigen::Matrix3Xd branch;                          ///< 3 x M, m
  Eigen::VectorXd overlap;                          ///< M, m
  Eigen::VectorXd normalForce;                      ///< M, fn (N), > 0 repulsive
  std::optional<Eigen::Matrix3Xd> tangentialForce;  ///< 3 x M, N; laws with friction only

  Index count() const { return static_cast<Index>(overlap.size()); }
  /// The normal force vector on i of contact c: -fn branch / |branch| (N).
  Eigen::Vector3d normalForceVector(Index c) const { return -normalForce[c] * branch.col(c).normalized(); }
};

/// Throw ConfigError unless idJ, centre, branch, normalForce and tangentialForce (if present) match
/// overlap (M), and every row has 0 <= id_i < id_j. Writers call it.
void requireConsistentContacts(const ContactData& data);

/// Write `data` to `file` by extension (see above): HDF5 with its XDMF sidecar, else CSV. Atomic like
/// every output (core/io/safe_output.hpp). Throws ConfigError for inconsistent data (or an HDF5 file
/// without HDF5 support, or one ending in .xmf), InputError if a file cannot be written.
void writeContacts(const std::filesystem::path& file, const ContactData& data);

/// Read an HDF5 contact file written by writeContacts(). Throws InputError "FILE: dataset PATH: problem"
/// for missing datasets or shapes that disagree; ConfigError without HDF5 support.
ContactData readContacts(const std::filesystem::path& file);

/// The contact file of the snapshot `snapshot`: "DIR/NAME_contacts.h5" for an HDF5 snapshot
/// "DIR/NAME.h5" (the same extension), "DIR/NAME_contacts.csv" for any other snapshot format.
std::filesystem::path contactPathFor(const std::filesystem::path& snapshot);

/// The XDMF sidecar of an HDF5 contact file (NAME.h5 -> NAME.xmf).
std::filesystem::path contactXdmfPath(const std::filesystem::path& file);

/// The temporal series of the contact files of a snapshot pattern: "out/snap_{step}.h5" ->
/// "out/snap_contacts_series.xmf"; without "{step}", "NAME_contacts_series.xmf" (see seriesPathFor()).
std::filesystem::path contactSeriesPathFor(const std::string& snapshotPattern);

}  // namespace polydem::io
