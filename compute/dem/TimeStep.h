// Time-step choice for the explicit DEM step: Rayleigh time, Hertz contact time, and the chosen dt with the
// reason and warnings a user should see. Formulas: /work/shared/design/physics-reference.md ("Time step").
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute {

// Rayleigh time T_R = pi R sqrt(rho / G) / (0.1631 nu + 0.8766) with G = E / (2 (1 + nu)) [s].
// radius [m], density [kg/m^3], youngsModulus [Pa], poissonRatio [-].
double rayleighTime(double radius, double density, double youngsModulus, double poissonRatio);

// Duration of an elastic Hertz impact t_H = 2.868 (m*^2 / (R* E*^2 v))^(1/5) [s] for the effective radius R* [m],
// effective mass m* [kg], effective modulus E* [Pa] and normal approach speed v [m/s].
double hertzContactTime(double effRadius, double effMass, double effModulus, double approachSpeed);

struct TimeStepInfo {
  double rayleighTime = 0;        // [s], at the smallest particle over the materials in use; 0 when there are no particles
  double dt = 0;                  // [s], the step to use
  double fractionOfRayleigh = 0;  // dt / rayleighTime; 0 when rayleighTime is 0
  bool automatic = false;         // true when dt came from dtFraction * rayleighTime (simulation.dt unset)
  std::string reason;             // one line: how dt was chosen, for logs and the CLI
  std::vector<std::string> warnings;  // what may go wrong with this dt (empty when it is comfortable)
};

// dt = sim.dt when set, else sim.dtFraction * T_R where T_R is the Rayleigh time minimised over the particles
// (each with its own material and radius). Warns when dt > 0.4 T_R and when the fastest initial particle would
// be resolved by fewer than 20 steps per Hertz contact. Errors when dt cannot be chosen (no particles and no
// simulation.dt) or the inputs it needs are invalid (call RunConfig::validate() first for the full list).
Result<TimeStepInfo> chooseTimeStep(const RunConfig& config);

}  // namespace pflow::compute
