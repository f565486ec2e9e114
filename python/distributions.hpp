#pragma once
// The Python Distribution: a DistributionSpec and the distribution made from it, shared by the binding files
// that take a distribution (start packings, jam, the cost model).
#include <memory>
#include <string>

#include "core/moments.hpp"
#include "core/size_distribution.hpp"
#include "python/convert.hpp"

namespace polydem::python {

class Distribution {
 public:
  /// Throws ConfigError naming the bad field (makeDistribution).
  explicit Distribution(const DistributionSpec& spec);
  const DistributionSpec& spec() const { return spec_; }
  const SizeDistribution& get() const { return *distribution_; }

 private:
  DistributionSpec spec_;
  std::unique_ptr<SizeDistribution> distribution_;
};

/// Build a spec from the keyword arguments of polydem.Distribution (the CLI's --dist options).
DistributionSpec specFrom(const std::string& kind, double rmin, double omega, double alpha, double sigma, double median,
                          double largeFraction, const std::string& fractionKind);
/// Moments as a dict (kurtosis None where undefined: a single radius).
py::dict momentsDict(const Moments& m);

}  // namespace polydem::python
