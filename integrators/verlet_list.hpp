#pragma once
// Verlet neighbour list for the DEM loop: pairs with gap <= skin from any broad-phase backend, stored
// CSR-style (contact::ContactList), plus particle-wall candidates. The caller rebuilds it when some
// particle has moved more than skin / 2 since the last build (then no pair can have closed a gap of
// `skin` unseen: each of the two moved at most skin / 2).
//
// The CSR rows are sorted (i, j) whatever order the backend reports, so the force loop sums in the
// same order for every backend. Buffers only grow: steady-state rebuilds do not allocate (the
// backend's own build may, depending on the backend).
//
// Threads (setThreads): the backend builds and searches in parallel (BroadPhase::setThreads) and hands
// its pairs over in chunks (PairChunks, no concatenated copy); the rows are counted and filled by threads
// that each own a contiguous range of rows, in the serial order, and sorted in parallel: the list is the
// same for every thread count.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/pair_chunks.hpp"
#include "contact/contact_list.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::integrators {

/// The rows of `outer` cut to the pairs within `skin` (the one pair predicate, broadphase::withinReach) and its
/// wall candidates to those within `skin` of their face, into `target`: rows keep the outer rows' order, so the
/// list is the one a build with `skin` would give. VerletList::refine() and the minimiser on MPI ranks.
void cutList(const contact::ContactList& outer, const SphereView& spheres, const Box& box, double skin,
             contact::ContactList& target);

// Two levels (setOuterSkin): build() asks the backend for the pairs within an outer skin S > skin and keeps
// them; refine() cuts the list to the skin from those candidates alone (O(P_S), no broad phase), which gives
// exactly the list build() would give while no pair has closed more than S - skin since the last build():
// outerDrift() bounds that closure. Positions are not wrapped between builds, so a refine needs centres
// within S of their last build.
class VerletList {
 public:
  /// `skin` in metres (>= 0; ConfigError otherwise).
  VerletList(std::unique_ptr<broadphase::BroadPhase> backend, double skin);

  /// Rebuild from the current spheres (centres inside the box: wrap periodic coordinates first).
  /// O(N + P) plus the backend's build.
  void build(const SphereView& spheres, const Box& box);
  /// Two levels: the backend's candidates within `outer` (>= skin, finite; ConfigError otherwise) at each
  /// build(); outer == skin is one level (the default). Takes effect at the next build.
  void setOuterSkin(double outer);
  double outerSkin() const { return outerSkin_; }
  bool twoLevel() const { return outerSkin_ > skin_; }
  /// The list from the candidates of the last build() alone (two levels only; std::logic_error otherwise),
  /// against the current spheres: the list build() would give if outerDrift() + 2 max dr <= S - skin.
  void refine(const SphereView& spheres, const Box& box);
  /// The two largest displacements since the last build(), summed (the most any pair can have closed),
  /// +inf when a centre is not finite. O(N).
  double outerDrift(const Eigen::Matrix3Xd& centres) const;
  /// refine() calls in all (a two-level build() cuts its list too, but counts as a build).
  std::int64_t refines() const { return refines_; }

  /// Also split the list into `blocks` thread blocks (ContactList::buildBlocks) at every build, for the
  /// threaded force loop; 0 or 1 = none (the default). Takes effect at the next build.
  void setBlocks(int blocks) { blocks_ = blocks; }
  /// OpenMP threads for the build (>= 1; ConfigError otherwise): the backend's and the CSR's. The list is
  /// identical for every thread count. Takes effect at the next build.
  void setThreads(int threads);

  /// Fill history keys for the current list from the particles' stored ids (pairKey / wallKey).
  void keys(std::span<const Index> ids, std::vector<std::uint64_t>& pairKeys,
            std::vector<std::uint64_t>& wallKeys) const;

  const contact::ContactList& list() const { return list_; }
  /// Centres at the last build (3 x N).
  const Eigen::Matrix3Xd& reference() const { return reference_; }
  /// Centres at the last build() through the backend (the outer candidates' build; reference() for one level).
  const Eigen::Matrix3Xd& outerReference() const { return twoLevel() ? outerReference_ : reference_; }
  /// Radii at the last build (N): with reference(), all a resumed run needs to rebuild the same list.
  const Eigen::VectorXd& referenceRadius() const { return referenceRadius_; }
  /// Set the build counter (a resumed run continues the count of the run that saved it).
  void setBuilds(std::int64_t builds) { builds_ = builds; }
  double skin() const { return skin_; }
  std::int64_t builds() const { return builds_; }
  const broadphase::BroadPhase& backend() const { return *backend_; }
  std::size_t memoryBytes() const;
  /// Transparent huge pages for the arrays a step reads (the list's rows and the build's centres), in advice
  /// slots from `slot` on; returns the next free slot (core/huge_pages.hpp).
  std::size_t adviseHugePages(HugePageAdvice& advice, std::size_t slot) const;
  /// Invariants against the spheres of the last build: rows ascending with j > i, every pair within
  /// the skin listed exactly once (brute-force check, O(N^2): tests only). Throws std::logic_error.
  void validate(const SphereView& spheres, const Box& box) const;

 private:
  std::unique_ptr<broadphase::BroadPhase> backend_;
  /// Rows and wall candidates from the backend's pairs (pairs_) within `reach`, into `target`.
  void fill(const SphereView& spheres, const Box& box, double reach, contact::ContactList& target);
  void finish(const SphereView& spheres);
  /// The list within the skin from the outer candidates (the work of refine(), also the last step of build()).
  void cutFromOuter(const SphereView& spheres, const Box& box);

  double skin_;
  double outerSkin_;
  std::int64_t builds_ = 0;
  std::int64_t refines_ = 0;
  contact::ContactList outer_;  ///< two levels: the candidates within outerSkin_ at the last build
  Eigen::Matrix3Xd outerReference_;
  int blocks_ = 0;
  int threads_ = 1;
  contact::ContactList list_;
  Eigen::Matrix3Xd reference_;
  Eigen::VectorXd referenceRadius_;
  broadphase::PairChunks pairs_;
  std::vector<Index> fill_;
};

}  // namespace polydem::integrators
