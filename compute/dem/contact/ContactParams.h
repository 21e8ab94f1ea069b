// Per material pair contact parameters, precomputed on the host into a plain struct that kernels read.
#pragma once
#include <cstdint>
#include <vector>

#include "common/Status.h"

namespace pflow::compute {

struct MaterialConfig;
struct MaterialPairConfig;

struct ContactParams {
  double effYoung = 0;       // E*  [Pa]:   1/E* = (1-nu_i^2)/E_i + (1-nu_j^2)/E_j
  double effShear = 0;       // G*  [Pa]:   1/G* = (2-nu_i)/G_i + (2-nu_j)/G_j
  double dampingCoeff = 0;   // c [-]: F_d = -c sqrt(S m*) v, chosen so the Hertz contact restitutes e exactly
  // The step correction of the normal dashpot: c is multiplied by 1 + a1 u + a2 u^2 + a3 u^3, where u = omega dt is
  // the step in units of the contact's present normal frequency (contact::normal::hertzNormal), so that the discrete
  // step restitutes e as the continuous contact does (calibrateDashpotForStep). All 0 when e = 1 or e < 0.1.
  float dashpotStep[3] = {0, 0, 0};  // float: the kernels use them in float (and read 12 bytes, not 24)
  double tangentialRatio = 0;  // sqrt(S_t / S_n) = sqrt(4 G* / E*), so the tangential dashpot costs no sqrt
  double restitution = 1;    // e [-], the requested value (kept for reports)
  double friction = 0;       // mu_s [-]
  double rollingFriction = 0;  // mu_r [-]
  // Adhesion (contact::cohesion): 0 none, 1 JKR, 2 constant (DMT). dgamma is the work of adhesion [J/m^2].
  int cohesion = 0;
  // Which of the pair's particles are fixed (MaterialConfig::fixed): bit 0 the row's material (i), bit 1 the
  // column's (j). In the padding after `cohesion`: the struct's size is unchanged.
  std::int32_t fixedSide = 0;
  double workOfAdhesion = 0;
  double jkrB = 0;      // sqrt(2 pi dgamma / E*) [m^1/2]: the JKR overlap is delta = a^2 / R* - jkrB sqrt(a)
  double jkrBreak = 0;  // (3/4) (pi dgamma / E*)^{2/3} [m^2/3]: a JKR contact breaks at delta = -jkrBreak R*^{1/3}
};

// The energy stored in a contact at overlap delta > 0, the work done on it since it formed at delta = 0: Hertz's
// (8/15) E* sqrt(R*) delta^{5/2}, JKR's potential (contact::cohesion::jkrEnergy, negative in the adhesive well),
// or Hertz's less the constant adhesion's F_0 delta. Host only (the energy detector).
double contactEnergy(const ContactParams& p, double effRadius, double overlap);

// The depth of a contact's adhesive energy well (the most kinetic energy one contact can release by forming),
// 0 without adhesion: JKR's potential where its force is 0, or 0.6 F_0 delta* for the constant model (delta* where
// Hertz balances F_0). Host only.
double adhesionWellDepth(const ContactParams& p, double effRadius);

// The adhesion constants of a pair with work of adhesion dgamma (ContactParams::jkrB, jkrBreak), for the table and tests.
void setCohesion(ContactParams& p, int model, double workOfAdhesion);

// Builds the nMaterials x nMaterials table (row-major, symmetric). Unset pair values are the
// arithmetic means of the two materials' values; MaterialPairConfig entries override them.
std::vector<ContactParams> buildContactTable(const std::vector<MaterialConfig>& materials,
                                             const std::vector<MaterialPairConfig>& pairs);

// The damping coefficient c for which a Hertz contact with damping force -c sqrt(S_n m*) v_n
// (S_n = 2 E* sqrt(R* delta), total normal force clipped at zero) has restitution e. The map is
// independent of E*, R*, m* and impact speed, so it is solved once per pair by integrating the
// dimensionless equation of motion and bisecting on c. e = 1 gives 0.
double dampingCoeffForRestitution(double e);

// The restitution realised by damping coefficient c (the forward map of the above), for tests.
double restitutionForDampingCoeff(double c);

// The restitution the discrete step realises for a normal impact (pflow's velocity Verlet and contact function,
// dimensionless: unit stiffness k = 4/3 E* sqrt(R*), unit mass, unit impact speed) with damping coefficient c,
// step correction `poly`, step h (in units of (m*/k)^{2/5} v^{-1/5}) and the contact's first overlap (1 - phase) h.
double restitutionOfStep(double c, const double poly[3], double h, double phase);

// The step correction (a1, a2, a3) for requested restitution e: least squares over contacts resolved by 9 to 160
// steps (h = 0.02 ... 0.36), averaged over the phase of the first overlap. e >= 1 or e < 0.1: zeros (below 0.1 the
// correction does not converge; such contacts keep the continuous coefficient).
void calibrateDashpotForStep(double e, double poly[3]);

// The linear-spring mapping others use, c = -2 sqrt(5/6) ln e / sqrt(ln^2 e + pi^2): exact for a
// linear spring, not for Hertz. Kept only so tests can show the difference.
double linearSpringDampingCoeff(double e);

}  // namespace pflow::compute
