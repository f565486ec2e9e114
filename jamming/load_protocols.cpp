#include "jamming/load_protocols.hpp"

namespace polydem::jamming {

LoadTestResult testJammingUnderLoad(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                    const LoadTestOptions& options) {
  switch (options.protocol) {
    case LoadProtocol::Sequential:
      return testSequentialLoading(spheres, box, network, options);
    case LoadProtocol::SingleLp:
      break;
  }
  return testSingleLoads(spheres, box, network, options);
}

const LoadTestSummary& summaryOf(const LoadTestResult& result) {
  return std::visit([](const auto& r) -> const LoadTestSummary& { return r; }, result);
}

}  // namespace polydem::jamming
