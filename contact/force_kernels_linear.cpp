// The force kernels of the linear spring-dashpot laws: frictionless, Cundall-Strack friction, LAMMPS history:
// every flag set (force_loop_impl.hpp). force_kernel_select.cpp picks one.
#include "contact/force_loop_impl.hpp"

namespace polydem::contact {

POLYDEM_FORCE_KERNEL_INSTANCES(LinearLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(LinearFrictionLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(LinearLammpsLaw)

}  // namespace polydem::contact
