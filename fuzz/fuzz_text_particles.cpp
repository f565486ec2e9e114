// libFuzzer target: io::readText on arbitrary bytes. Properties: only InputError escapes the reader
// (anything else, a crash or a sanitizer report is a finding); a file that reads writes back and reads
// again to the same data, bit for bit (the text format's round-trip promise).
#include <cstdint>
#include <cstring>

#include "core/errors.hpp"
#include "core/io/particle_file.hpp"
#include "fuzz/fuzz_support.hpp"

namespace {

bool bitEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  // memcmp must not see the null buffer of an empty matrix.
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

bool sameOptional(const std::optional<Eigen::Matrix3Xd>& a, const std::optional<Eigen::Matrix3Xd>& b) {
  return a.has_value() == b.has_value() && (!a || bitEqual(*a, *b));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace polydem;
  const auto file = fuzz::scratch("particles.txt");
  fuzz::writeBytes(file, data, size);
  io::ParticleData read;
  try {
    // Walls by default: exercises the walled-box checks unless the file names its boundaries.
    read = io::readText(file, {Boundary::Wall, Boundary::Periodic, Boundary::Wall});
  } catch (const InputError&) {
    return 0;  // rejected with a message: the expected outcome for most inputs
  }
  const auto copy = fuzz::scratch("copy.txt");
  io::writeText(copy, read);
  const io::ParticleData back = io::readText(copy);
  if (!(back.box == read.box)) fuzz::broken("box changed on round trip");
  if (!bitEqual(back.position, read.position) || !bitEqual(back.radius, read.radius)) {
    fuzz::broken("positions or radii changed on round trip");
  }
  if (!sameOptional(back.velocity, read.velocity)) fuzz::broken("velocities changed on round trip");
  if (!sameOptional(back.angularVelocity, read.angularVelocity)) fuzz::broken("angular velocities changed");
  if (back.id != read.id) fuzz::broken("ids changed on round trip");
  if (std::memcmp(&back.time, &read.time, sizeof(double)) != 0) fuzz::broken("time changed on round trip");
  if (back.attributes != read.attributes) fuzz::broken("attributes changed on round trip");
  return 0;
}
