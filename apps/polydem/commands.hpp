#pragma once
// Subcommands of the polydem program. Each registers itself on the CLI11 app and returns a runner.
#include <functional>

// CLI11 only by name: the header costs 4-13 s of compile time in every file that includes it (its validators are
// objects defined in the header), so only the files that build options include it.
namespace CLI {
class App;
}  // namespace CLI

namespace polydem::app {

using Runner = std::function<int()>;

Runner addGenerate(CLI::App& app);
Runner addPairs(CLI::App& app);
Runner addExample(CLI::App& app);
Runner addRelax(CLI::App& app);
Runner addJam(CLI::App& app);
Runner addAnalyze(CLI::App& app);
Runner addBench(CLI::App& app);
Runner addPredict(CLI::App& app);
Runner addMinimise(CLI::App& app);
Runner addConvert(CLI::App& app);
Runner addLammpsNeighbor(CLI::App& app);

}  // namespace polydem::app
