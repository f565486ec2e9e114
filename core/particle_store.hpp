#pragma once
// Particle data as a structure of arrays: one Eigen array per property, one column per particle.
// Optional arrays (rotation) have zero columns unless the scene's Features ask for them.
#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/huge_pages.hpp"
#include "core/types.hpp"

namespace polydem {

/// Per-scene switches. "Off" means the arrays do not exist, not that they are zero.
struct Features {
  bool rotation = false;  ///< angular velocity, torque, inverse moment of inertia
};

/// Everything a broad phase may look at: centres (3 x N, m) and radii (N, m). Non-owning.
struct SphereView {
  Eigen::Ref<const Eigen::Matrix3Xd> centre;
  Eigen::Ref<const Eigen::VectorXd> radius;
  Index count() const { return static_cast<Index>(radius.size()); }
};

class ParticleStore {
 public:
  ParticleStore() : ParticleStore(0, Features{}) {}
  /// `count` particles with zeroed state, unit mass, ids 0..count-1.
  ParticleStore(Index count, Features features);

  Index count() const { return static_cast<Index>(radius_.size()); }
  const Features& features() const { return features_; }

  Eigen::Matrix3Xd& position() { return position_; }
  const Eigen::Matrix3Xd& position() const { return position_; }
  Eigen::Matrix3Xd& velocity() { return velocity_; }
  const Eigen::Matrix3Xd& velocity() const { return velocity_; }
  Eigen::Matrix3Xd& force() { return force_; }
  const Eigen::Matrix3Xd& force() const { return force_; }
  Eigen::VectorXd& radius() { return radius_; }
  const Eigen::VectorXd& radius() const { return radius_; }
  Eigen::VectorXd& inverseMass() { return inverseMass_; }
  const Eigen::VectorXd& inverseMass() const { return inverseMass_; }
  /// Stable ids: survive reorder(); unique within a store.
  std::vector<Index>& id() { return id_; }
  const std::vector<Index>& id() const { return id_; }

  Eigen::Matrix3Xd& angularVelocity();
  const Eigen::Matrix3Xd& angularVelocity() const;
  Eigen::Matrix3Xd& torque();
  const Eigen::Matrix3Xd& torque() const;
  Eigen::VectorXd& inverseInertia();
  const Eigen::VectorXd& inverseInertia() const;

  SphereView spheres() const { return {position_, radius_}; }

  /// Set masses (and moments of inertia if rotation is on) of solid spheres of uniform density (kg/m^3).
  void setMassesFromDensity(double density);

  /// Permute particles: new slot k holds old particle order[k]. Ids travel with the particles. O(N).
  void reorder(std::span<const Index> order);

  /// Position of the particle with stored id `id`, or -1. O(N); for tests and reports.
  Index slotOfId(Index id) const;

  /// Transparent huge pages for the per-particle arrays (core/huge_pages.hpp), in advice slots from
  /// `slot` on; returns the next free slot. The ids are left out (no step reads them).
  std::size_t adviseHugePages(HugePageAdvice& advice, std::size_t slot) const;

 private:
  Features features_;
  Eigen::Matrix3Xd position_, velocity_, force_;
  Eigen::VectorXd radius_, inverseMass_;
  std::vector<Index> id_;
  Eigen::Matrix3Xd angularVelocity_, torque_;  // 3 x 0 unless features_.rotation
  Eigen::VectorXd inverseInertia_;             // empty unless features_.rotation
};

}  // namespace polydem
