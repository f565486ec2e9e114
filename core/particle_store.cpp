#include "core/particle_store.hpp"

#include <numeric>

#include "core/errors.hpp"

namespace polydem {

ParticleStore::ParticleStore(Index count, Features features)
    : features_(features),
      position_(Eigen::Matrix3Xd::Zero(3, count)),
      velocity_(Eigen::Matrix3Xd::Zero(3, count)),
      force_(Eigen::Matrix3Xd::Zero(3, count)),
      radius_(Eigen::VectorXd::Zero(count)),
      inverseMass_(Eigen::VectorXd::Ones(count)),
      id_(static_cast<std::size_t>(count)) {
  if (count < 0) throw ConfigError("particle count must be >= 0");
  std::iota(id_.begin(), id_.end(), Index{0});
  if (features_.rotation) {
    angularVelocity_ = Eigen::Matrix3Xd::Zero(3, count);
    torque_ = Eigen::Matrix3Xd::Zero(3, count);
    inverseInertia_ = Eigen::VectorXd::Ones(count);
  }
}

namespace {
void requireRotation(const Features& f, const char* what) {
  if (!f.rotation) {
    throw ConfigError(std::string(what) + " requested but the scene has no rotation (Features::rotation is off)");
  }
}
}  // namespace

Eigen::Matrix3Xd& ParticleStore::angularVelocity() {
  requireRotation(features_, "angular velocity");
  return angularVelocity_;
}
const Eigen::Matrix3Xd& ParticleStore::angularVelocity() const {
  requireRotation(features_, "angular velocity");
  return angularVelocity_;
}
Eigen::Matrix3Xd& ParticleStore::torque() {
  requireRotation(features_, "torque");
  return torque_;
}
const Eigen::Matrix3Xd& ParticleStore::torque() const {
  requireRotation(features_, "torque");
  return torque_;
}
Eigen::VectorXd& ParticleStore::inverseInertia() {
  requireRotation(features_, "moment of inertia");
  return inverseInertia_;
}
const Eigen::VectorXd& ParticleStore::inverseInertia() const {
  requireRotation(features_, "moment of inertia");
  return inverseInertia_;
}

void ParticleStore::setMassesFromDensity(double density) {
  if (!(density > 0.0)) throw ConfigError("density must be > 0");
  for (Index i = 0; i < count(); ++i) {
    const double r = radius_[i];
    const double mass = density * 4.0 / 3.0 * kPi * r * r * r;
    inverseMass_[i] = 1.0 / mass;
    if (features_.rotation) inverseInertia_[i] = 1.0 / (0.4 * mass * r * r);  // solid sphere
  }
}

void ParticleStore::reorder(std::span<const Index> order) {
  const Index n = count();
  if (static_cast<Index>(order.size()) != n) throw ConfigError("reorder: permutation has the wrong length");
  auto permuteCols = [&](Eigen::Matrix3Xd& m) {
    if (m.cols() == 0) return;
    Eigen::Matrix3Xd out(3, n);
    for (Index k = 0; k < n; ++k) out.col(k) = m.col(order[k]);
    m.swap(out);
  };
  auto permuteVec = [&](Eigen::VectorXd& v) {
    if (v.size() == 0) return;
    Eigen::VectorXd out(n);
    for (Index k = 0; k < n; ++k) out[k] = v[order[k]];
    v.swap(out);
  };
  permuteCols(position_);
  permuteCols(velocity_);
  permuteCols(force_);
  permuteCols(angularVelocity_);
  permuteCols(torque_);
  permuteVec(radius_);
  permuteVec(inverseMass_);
  permuteVec(inverseInertia_);
  std::vector<Index> ids(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) ids[k] = id_[order[k]];
  id_.swap(ids);
}

Index ParticleStore::slotOfId(Index id) const {
  for (Index k = 0; k < count(); ++k) {
    if (id_[k] == id) return k;
  }
  return -1;
}

void assertionFailed(const char* condition, const char* message, const char* file, int line) {
  throw std::logic_error(std::string(file) + ":" + std::to_string(line) + ": assertion " + condition +
                         " failed: " + message);
}

std::size_t ParticleStore::adviseHugePages(HugePageAdvice& advice, std::size_t slot) const {
  for (const Eigen::Matrix3Xd* m : {&position_, &velocity_, &force_, &angularVelocity_, &torque_}) {
    advice.apply(slot++, m->data(), static_cast<std::size_t>(m->size()) * sizeof(double));
  }
  for (const Eigen::VectorXd* v : {&radius_, &inverseMass_, &inverseInertia_}) {
    advice.apply(slot++, v->data(), static_cast<std::size_t>(v->size()) * sizeof(double));
  }
  return slot;
}

}  // namespace polydem
