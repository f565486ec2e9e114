// The force kernels of the linear laws with mass-velocity damping: frictionless, Cundall-Strack friction,
// LAMMPS history: every flag set (force_loop_impl.hpp). force_kernel_select.cpp picks one.
#include "contact/force_loop_impl.hpp"

namespace polydem::contact {

POLYDEM_FORCE_KERNEL_INSTANCES(LinearMassVelocityLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(LinearMassVelocityFrictionLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(LinearMassVelocityLammpsLaw)

}  // namespace polydem::contact
