// The force kernels of the Hertzian laws: frictionless, Cundall-Strack friction, Hertz-Mindlin:
// every flag set (force_loop_impl.hpp). force_kernel_select.cpp picks one.
#include "contact/force_loop_impl.hpp"

namespace polydem::contact {

POLYDEM_FORCE_KERNEL_INSTANCES(HertzLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(HertzFrictionLaw)
POLYDEM_FORCE_KERNEL_INSTANCES(HertzMindlinLaw)

}  // namespace polydem::contact
