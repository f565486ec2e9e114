// The dispatch that picks one of the shipped force kernels (instantiated in force_kernels_*.cpp: every
// law x 8 flag sets), and the contact statistics of a state.
#include <fmt/format.h>

#include <Eigen/Core>
#include <cmath>
#include <type_traits>

#include "contact/force_loop.hpp"
#include "contact/hertz_mindlin.hpp"
#include "core/errors.hpp"

namespace polydem::contact {

namespace {

template <class Law>
typename Law::Params paramsFor(const ContactModel& model) {
  typename Law::Params p{};
  if constexpr (std::is_same_v<typename Law::NormalLaw, LinearNormal>) {
    p.normal = model.linearParams();
  } else if constexpr (std::is_same_v<typename Law::NormalLaw, LinearMassVelocityNormal>) {
    p.normal = model.massVelocityParams();
  } else {
    p.normal = model.hertzParams();
  }
  if constexpr (std::is_same_v<typename Law::TangentialLaw, CundallStrack> ||
                std::is_same_v<typename Law::TangentialLaw, LammpsHistory>) {
    p.tangential = model.tangentialParams();
  }
  if constexpr (std::is_same_v<typename Law::TangentialLaw, HertzMindlin>) p.tangential = hertzMindlinParams(model);
  return p;
}

template <class Law, KernelFlags kFlags>
void runKernel(const ContactModel& model, const ForceContext& ctx) {
  computeForces<Law, kFlags>(paramsFor<Law>(model), ctx);
}

template <class Law>
ForceKernelFn pickFlags(KernelFlags flags) {
  const int code = (flags.walls ? 1 : 0) | (flags.gravity ? 2 : 0) | (flags.viscous ? 4 : 0);
  switch (code) {
    case 0:
      return &runKernel<Law, KernelFlags{false, false, false}>;
    case 1:
      return &runKernel<Law, KernelFlags{true, false, false}>;
    case 2:
      return &runKernel<Law, KernelFlags{false, true, false}>;
    case 3:
      return &runKernel<Law, KernelFlags{true, true, false}>;
    case 4:
      return &runKernel<Law, KernelFlags{false, false, true}>;
    case 5:
      return &runKernel<Law, KernelFlags{true, false, true}>;
    case 6:
      return &runKernel<Law, KernelFlags{false, true, true}>;
    default:
      return &runKernel<Law, KernelFlags{true, true, true}>;
  }
}

template <class Law>
ForceKernel make(KernelFlags flags) {
  std::string name = fmt::format("{}+{}", Law::NormalLaw::kName, Law::TangentialLaw::kName);
  std::string features;
  if (flags.walls) features += " walls";
  if (flags.gravity) features += " gravity";
  if (flags.viscous) features += " viscous";
  name += features.empty() ? std::string(" [no walls, gravity or damping]") : " [" + features.substr(1) + "]";
  return {pickFlags<Law>(flags), Law::kUsesRotation, Law::kHistorySize, name};
}

}  // namespace

ForceKernel selectForceKernel(const ContactModel& model, KernelFlags flags, bool general) {
  const bool linear = model.parameters().normal == NormalModel::Linear;
  const bool friction = general || model.parameters().usesFriction();
  if (general) flags = {true, true, true};
  if (friction && model.parameters().tangential == TangentialModel::HertzMindlin) return make<HertzMindlinLaw>(flags);
  const bool lammps = model.parameters().tangential == TangentialModel::LammpsHistory;
  if (model.parameters().damping == DampingModel::MassVelocity) {
    if (friction && lammps) return make<LinearMassVelocityLammpsLaw>(flags);
    return friction ? make<LinearMassVelocityFrictionLaw>(flags) : make<LinearMassVelocityLaw>(flags);
  }
  if (linear && friction && lammps) return make<LinearLammpsLaw>(flags);
  if (linear) return friction ? make<LinearFrictionLaw>(flags) : make<LinearLaw>(flags);
  return friction ? make<HertzFrictionLaw>(flags) : make<HertzLaw>(flags);
}

ContactStats measureContacts(const ContactModel& model, const ForceContext& ctx) {
  ContactStats s;
  const bool hasHistory = ctx.pairHistory != nullptr && ctx.pairHistory->width() > 0;
  const CundallStrack::Params tp = model.tangentialParams();
  const bool linear = model.parameters().normal == NormalModel::Linear;
  // Hertz-Mindlin histories hold the spring force F (N), whose energy is |F|^2 / (2 k_t); Cundall-Strack
  // ones the displacement xi (m), whose energy is k_t |xi|^2 / 2.
  const bool mindlin = model.parameters().tangential == TangentialModel::HertzMindlin;
  const double mindlinRatio = mindlin ? mindlinStiffnessRatio(model.parameters()) : 0.0;
  auto tangentialStiffness = [&](double overlap, double reff) {
    if (linear) return tp.stiffnessRatio * LinearNormal::pairStiffness(model.linearParams(), reff);
    return tp.stiffnessRatio * model.parameters().stiffness * std::sqrt(reff) * std::sqrt(overlap);
  };
  auto tangentialEnergy = [&](double overlap, double reff, double sq) {
    if (mindlin) return 0.5 * sq / (mindlinRatio * model.parameters().stiffness * std::sqrt(reff * overlap));
    return 0.5 * tangentialStiffness(overlap, reff) * sq;
  };
  auto consider = [&](double ratio, Index i, Index j) {
    if (ratio > s.maxOverlapRatio) {
      s.maxOverlapRatio = ratio;
      s.maxOverlapI = i;
      s.maxOverlapJ = j;
    }
  };
  const ContactList& list = *ctx.list;
  for (Index i = 0; i < ctx.count; ++i) {
    const Eigen::Vector3d xi = Eigen::Map<const Eigen::Vector3d>(ctx.position + 3 * i);
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      Eigen::Vector3d d = xi - Eigen::Map<const Eigen::Vector3d>(ctx.position + 3 * j);
      for (int k = 0; k < 3; ++k) {  // the kernel's minimum image (halfLength = inf on walled axes)
        if (d[k] > ctx.halfLength[k]) {
          d[k] -= ctx.length[k];
        } else if (d[k] < -ctx.halfLength[k]) {
          d[k] += ctx.length[k];
        }
      }
      const double dist = d.norm();
      const double ri = ctx.radius[i], rj = ctx.radius[j];
      const double overlap = ri + rj - dist;
      if (!(overlap > 0.0)) continue;
      ++s.contacts;
      const double reff = ri * rj / (ri + rj);
      s.elasticEnergy += model.normalEnergy(overlap, reff);
      if (hasHistory) {
        const double* xi3 = ctx.pairHistory->values(static_cast<std::size_t>(c));
        const double sq = xi3[0] * xi3[0] + xi3[1] * xi3[1] + xi3[2] * xi3[2];
        s.elasticEnergy += tangentialEnergy(overlap, reff, sq);
      }
      consider(overlap / std::min(ri, rj), i, j);
    }
  }
  const bool wallHistory = ctx.wallHistory != nullptr && ctx.wallHistory->width() > 0;
  for (std::size_t c = 0; c < list.wallParticle.size(); ++c) {
    const Index i = list.wallParticle[c];
    const int face = list.wallFace[c];
    const int axis = face >> 1;
    const double gap = (face & 1) ? ctx.length[axis] - ctx.position[3 * i + axis] : ctx.position[3 * i + axis];
    const double overlap = ctx.radius[i] - gap;
    if (!(overlap > 0.0)) continue;
    ++s.wallContacts;
    s.elasticEnergy += model.normalEnergy(overlap, ctx.radius[i]);
    if (wallHistory) {
      const double* xi3 = ctx.wallHistory->values(c);
      const double sq = xi3[0] * xi3[0] + xi3[1] * xi3[1] + xi3[2] * xi3[2];
      s.elasticEnergy += tangentialEnergy(overlap, ctx.radius[i], sq);
    }
    consider(overlap / ctx.radius[i], i, -1 - face);
  }
  return s;
}

}  // namespace polydem::contact
