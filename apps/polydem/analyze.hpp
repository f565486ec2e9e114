#pragma once
// `polydem analyze`, internal to the program: its options and the parts of its run, one file per concept
// (analyze.cpp: options, validation and the run; analyze_contacts.cpp: the contact network and its
// statistics; analyze_jamming.cpp: the jamming tests; analyze_structure.cpp: structure of any
// configuration).
#include <optional>
#include <string>
#include <vector>

#include "core/io/particle_file.hpp"
#include "core/types.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::app::analyze {

struct AnalyzeOptions {
  std::string input;
  double contactGap = 0.0;
  double pressure = 0.0;
  std::string broadPhase = "hgrid-td";
  std::string coordinationCsv;
  std::string correlationCsv;
  double correlationMax = 3.0;
  int correlationBins = 600;
  bool certify = false;
  Index removeSphere = -1;
  std::string motionCsv;
  double loadGap = 0.05;
  double displacementLimit = 1e-3;
  int loads = 2;
  std::string lpSolver = "auto";
  int subpackingRounds = 1;
  std::string loadTest = "sequential";
  double beta = 0.01;
  double maxLimit = 0.05;
  double meanLimit = 1e-3;
  int maxSteps = 10;
  bool noLocalRattlers = false;
  bool strict = false;
  bool skipIdeal = false;
  double leakCollisions = 0.0;
  int leakBlocks = 20;
  double leakTolerance = 1e-3;
  double leakDrift = 1.5;
  bool structureOnly = false;
  bool order = false;
  std::string channelsCsv;
  std::string skCsv;
  double skMax = 20.0;
  double skMaxVectors = 2e6;
  std::vector<std::string> velocityThreshold;  // empty (or "") with the flag alone: 1e-4
  // Set from the parsed options by the runner:
  bool velocityRattlers = false;       ///< --velocity-rattlers given
  double velocityRattlerLimit = 1e-4;  ///< its threshold
};

/// Write "header\na,b\n..." with 10 significant digits.
std::string csvText(const std::string& header, const std::vector<double>& a, const std::vector<double>& b);

/// Sum of the sphere volumes.
double solidVolume(const io::ParticleData& data);

/// The first two lines of every report: spheres, box, size ratio, packing fraction.
void printHeader(const AnalyzeOptions& opt, const io::ParticleData& data);

/// The contact network of a valid hard-sphere packing, with the tolerance and pressure it rests on.
struct ContactAnalysis {
  std::optional<double> pressure;  ///< reduced pressure, if known
  jamming::ContactOptions contact;
  jamming::PackingValidity validity;
  jamming::ContactNetwork net;
};

/// Pressure, contact tolerance, validity check and contact network. Throws ConfigError without a pressure
/// or contact gap, InputError for an invalid packing or a box too small for the contact search.
ContactAnalysis computeContacts(const AnalyzeOptions& opt, const io::ParticleData& data);

/// Prints the header and the contact statistics (density bound, pressure, smallest gap, contacts,
/// rattlers, isostaticity, Z(tau)) and writes --z-csv and --gr-csv.
void reportContacts(const AnalyzeOptions& opt, const io::ParticleData& data, const ContactAnalysis& contacts);

/// --certify: the ideal-contact LP test and the load test, with --motion-csv.
void certifyJamming(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork& net);

/// --leak-test: the pressure-leak test (without the --remove sphere).
void runLeakTest(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork& net);

/// --order, --channels-csv, --sk-csv, --velocity-rattlers: structure of any configuration. `net` (the
/// contact network, if computed) lets the speed rattlers be compared with the contact-count ones.
void analyzeStructure(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork* net);

}  // namespace polydem::app::analyze
