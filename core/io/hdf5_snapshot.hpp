#pragma once
// HDF5 snapshots of one configuration, with an XDMF sidecar so ParaView and VisIt open them directly.
//
// Layout (N particles, SI units):
//   /particles/position   N x 3 double
//   /particles/velocity   N x 3 double (only if ParticleData::velocity is present)
//   /particles/angular_velocity  N x 3 double, rad/s (only if ParticleData::angularVelocity is present)
//   /particles/radius     N double
//   /particles/id         N int32
//   /box/lengths          3 double
//   /box/periodic         3 int8 (1 periodic, 0 wall; x y z)
//   /parameters           group; one scalar string attribute per ParticleData::attributes entry
//   root attribute time   double (s); optional on read (0 if absent)
//
// The sidecar (xdmfPath(file), e.g. snap.h5 -> snap.xmf) is XDMF 3: a Polyvertex grid with one vertex
// per particle, position as Geometry XYZ and radius, id, velocity, angular_velocity as node attributes. It refers to
// the .h5 by file name only, so keep the two files side by side.
//
// Reading is strict, like text files: every problem throws InputError naming the file and the dataset
// ("snap.h5: dataset /particles/radius: expected 100 entries, got 99"). HDF5's own error printing is
// switched off for the duration of each call and restored afterwards.
//
// Built without HDF5 (POLYDEM_WITH_HDF5=OFF), readSnapshot() and writeSnapshot() throw ConfigError.
#include <filesystem>

#include "core/io/contacts.hpp"
#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Write `data` to `file` (replacing it) and the XDMF sidecar xdmfPath(file), each atomically (temporary
/// beside it, renamed when complete) and byte-deterministic (no object time stamps: the same data gives
/// the same bytes). Throws ConfigError if the arrays of `data` disagree in size, an attribute key is empty
/// or `file` ends in .xmf; InputError if a file cannot be written. Values are stored as they are (no validation),
/// positions bit-exact.
void writeSnapshot(const std::filesystem::path& file, const ParticleData& data);

/// Read a snapshot written by writeSnapshot() (or any file with the same layout). Validates like
/// readText(): finite values, positive radii, unique ids, centres inside walled axes; centres outside
/// [0, L) on periodic axes are wrapped. Throws InputError "FILE: dataset PATH: problem".
ParticleData readSnapshot(const std::filesystem::path& file);

/// The HDF5 half of writeContacts() (core/io/contacts.hpp, which has the layout): `file` and its sidecar
/// contactXdmfPath(file), each atomically and byte-deterministic. Call writeContacts(), which checks the data.
void writeContactsHdf5(const std::filesystem::path& file, const ContactData& data);

/// The XDMF sidecar of an HDF5 snapshot: `file` with its extension replaced by .xmf.
std::filesystem::path xdmfPath(const std::filesystem::path& file);

}  // namespace polydem::io
