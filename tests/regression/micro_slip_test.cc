// Oblique impacts across the micro-slip regime, Chung & Ooi (2011) tests 4-8 (7 and 8, two spheres, at the end): an alumina sphere (R = 2.5 mm,
// E = 380 GPa, nu = 0.23, rho = 4000, mu = 0.092, e = 0.98) at 3.9 m/s from 2 to 80 degrees off the normal (test 4);
// an aluminium-alloy sphere (R = 0.1 m, E = 70 GPa, nu = 0.33, rho = 2700, mu = 0.4, e = 0.5) at a normal 0.2 m/s
// with tangential velocities from 0.02 to 1.6 m/s (test 5) and with spins (no tangential velocity) giving its contact
// point 0.02 to 1.6 m/s (test 6). At small incidence the tangential spring, not friction, decides the rebound. Three
// ways of computing the same impact must agree at pflow's default step (0.2 Rayleigh times):
//   - the sphere on a rigid plane (the wall kernel),
//   - two identical spheres in a mirror-symmetric collision (the pair kernel; the same dimensionless problem:
//     Hertz-Mindlin outcomes depend on the incidence, mu, e and the stiffness ratio 2(1-nu)/(2-nu), which are the same
//     for an elastic pair and for a sphere on a rigid wall),
//   - an independent integration of the same contact law (Hertz, the dashpot for e, Mindlin's spring 8 G* a with its
//     dashpot and Coulomb cap, lever arm R - delta/2) for the sphere on the plane, at a step 1/50 of pflow's,
// and, in gross sliding, the rigid-body closed form: the spin changes by (5/2) mu (1 + e) v_n / R. Measured: the
// contact point's tangential velocity ratio u'/u and the spin change (omega' - omega) R / |u|. The published curves and
// the Maw-Barber-Fawcett analysis are not in this repository (docs/accuracy.md, "Micro-slip").
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

struct Material {
  double E, nu, rho, R, mu, e;
};
const Material kAlumina{380e9, 0.23, 4000, 2.5e-3, 0.092, 0.98};
const Material kAluminium{70e9, 0.33, 2700, 0.1, 0.4, 0.5};
const Material kNylon{2.5e9, 0.4, 1000, 0.1, 0.4, 0.5};  // test 6's second sphere

// The incoming motion of the sphere that hits the plane (or of the lower sphere of the pair, seen from the upper):
// normal speed vn (towards), tangential vt along x, spin w about y.
struct Incoming {
  double vn, vt, w;
};

struct Rebound {
  double tangentialRatio = 0;  // u' / u: the contact point's tangential velocity after over before
  double spin = 0;             // (w' - w) R / |u|
};

// The contact point's tangential velocity of a sphere below its contact (contact at +R z from its centre) and of one
// above the plane (contact at -R z): u = v_x + R w_y and v_x - R w_y.
// `phase` in [0, 1): where within a step the contact begins (the initial gap is (1 + phase) steps of approach at the
// default step); negative: a fixed gap.
Rebound pflowImpact(const Material& m, bool pair, Incoming in, double phase = -1) {
  const double gap = phase >= 0 ? (1 + phase) * in.vn * 0.2 * compute::rayleighTime(m.R, m.rho, m.E, m.nu) : 1e-7 * m.R / 2.5e-3;
  RunConfig c;
  c.materials = {material("sphere", m.E, m.nu, m.rho, m.e, m.mu), rigid(m.e, m.mu)};
  compute::MaterialPairConfig wall;
  wall.a = 0, wall.b = 1, wall.restitution = m.e, wall.friction = m.mu;
  c.pairs = {wall};
  const double u0 = in.vt - m.R * in.w;  // at the contact point of the sphere on the plane
  if (pair) {
    // The lower sphere carries half the relative motion, the upper its image under a half turn about the y axis through
    // the contact point (velocities reversed, the y-spin kept); the lower sphere's contact point is at its top, so a
    // spin -w/2 on each gives the relative contact-point velocity vt - R w of the sphere on the plane.
    addParticle(c, {0, 0, -m.R - gap / 2}, m.R, 0, {0.5 * in.vt, 0, 0.5 * in.vn}, {0, -0.5 * in.w, 0});
    addParticle(c, {0, 0, m.R + gap / 2}, m.R, 0, {-0.5 * in.vt, 0, -0.5 * in.vn}, {0, -0.5 * in.w, 0});
  } else {
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 1, "floor")};
    addParticle(c, {0, 0, m.R + gap}, m.R, 0, {in.vt, 0, -in.vn}, {0, in.w, 0});
  }
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1e3;
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return {};
  const double tc = hertzImpact(m.E / (1 - m.nu * m.nu), m.R, sphereMass(m.R, m.rho), in.vn).contactTime;
  EXPECT_TRUE(sim.value()->runUntil(3 * tc + gap / in.vn).isOk());
  const auto snap = sim.value()->snapshot({"velocity", "angular_velocity", "id"});
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const Vec3d* w = snap.find("angular_velocity")->as<Vec3d>();
  const Gid* id = snap.find("id")->as<Gid>();
  if (pair) {
    const std::size_t lower = id[0] == 0 ? 0 : 1;
    // Relative to the upper sphere (its mirror image): twice the lower sphere's contact-point velocity.
    const double u = 2 * (v[lower].x + m.R * w[lower].y);
    return {u / u0, (-2 * w[lower].y - in.w) * m.R / std::fabs(u0)};
  }
  return {(v[0].x - m.R * w[0].y) / u0, (w[0].y - in.w) * m.R / std::fabs(u0)};
}

// The same contact law for the sphere on the plane, integrated independently (velocity Verlet, 1/50 of pflow's step).
// `tangentialDamping` scales the tangential dashpot (1: pflow's law; test 6's comparison with the published curve
// varies it).
Rebound referenceImpact(const Material& m, Incoming in, double tangentialDamping = 1) {
  const double Es = m.E / (1 - m.nu * m.nu), G = m.E / (2 * (1 + m.nu)), Gs = G / (2 - m.nu);
  const double mass = sphereMass(m.R, m.rho), I = 0.4 * mass * m.R * m.R;
  const double c = compute::dampingCoeffForRestitution(m.e), ratio = std::sqrt(4 * Gs / Es);
  const double dt = 0.2 * compute::rayleighTime(m.R, m.rho, m.E, m.nu) / 50;
  double z = m.R, vz = -in.vn, vx = in.vt, wy = in.w, xi = 0, fz = 0, fx = 0, ty = 0;
  auto forces = [&](double h) {
    fz = fx = ty = 0;
    const double d = m.R - z;
    if (d <= 0) {
      xi = 0;
      return;
    }
    const double a = std::sqrt(m.R * d), damp = c * std::sqrt(2 * Es * a * mass);
    const double fn = std::max(0.0, 4.0 / 3.0 * Es * a * d - damp * vz);
    const double l = m.R - 0.5 * d, u = vx - l * wy, kt = 8 * Gs * a;
    xi += h * u;
    double ft = -kt * xi - tangentialDamping * damp * ratio * u;
    if (std::fabs(ft) > m.mu * fn) {
      ft = ft > 0 ? m.mu * fn : -m.mu * fn;
      xi = -ft / kt;
    }
    fz = fn, fx = ft, ty = -l * ft;  // the torque about y of F_t applied at -l z
  };
  bool touched = false;
  for (long k = 0; k < 100000000; ++k) {
    vz += 0.5 * dt * fz / mass, vx += 0.5 * dt * fx / mass, wy += 0.5 * dt * ty / I;
    z += dt * vz;
    forces(dt);
    vz += 0.5 * dt * fz / mass, vx += 0.5 * dt * fx / mass, wy += 0.5 * dt * ty / I;
    touched |= z < m.R;
    if (touched && z > m.R) break;
  }
  const double u0 = in.vt - m.R * in.w;
  return {(vx - m.R * wy) / u0, (wy - in.w) * m.R / std::fabs(u0)};
}

// Every case of a test: the three computations, printed, and held together where they are known to agree.
//   - The wall kernel against the converged model: u'/u to `nearTol` where the contact point's incidence |u| / v_n is
//     below 0.25 and to `farTol` from it, the spin change to 1 % of its gross-sliding value. Test 4 (e = 0.98): 0.045
//     and 0.005; the 0.045 is the curve's steep stretch (u'/u falls from 0.95 to -0.05 between 2 and 10 degrees), where
//     pflow's default step leaves u'/u 0.03-0.04 below the converged value at 5 degrees whatever the phase. Tests 5 and
//     6 (e = 0.5): 0.015 throughout. Before the tangential dashpot and displacement were counted over the part of a
//     step in contact (docs/accuracy.md, "Micro-slip"), a contact beginning late in a step slid from its first step
//     and kept sliding: u'/u 0.12-0.23 against 0.04 at |u|/v_n = 0.1, and worse at smaller steps.
//   - The wall kernel against the rigid-body closed form in gross sliding (|u| / v_n >= 4): the spin change to 0.5 %.
//   - The pair kernel against the wall kernel: u'/u to 0.01 and the spin change to 1 % up to |u| / v_n = 2; in gross
//     sliding the pair's spin change comes out up to 2.8 % below the wall's and the closed form (the translating
//     pair's line of centres turns during the contact, which a sphere on a plane's does not), held to 3.5 % so that it
//     does not grow unseen.
void check(const char* test, const Material& m, const std::vector<Incoming>& cases, double nearTol, double farTol) {
  std::printf("%s\n  |u|/vn  u'/u: wall    pair    reference | spin change: wall   pair    reference  gross-sliding\n", test);
  for (const Incoming& in : cases) {
    const Rebound w = pflowImpact(m, false, in), p = pflowImpact(m, true, in), r = referenceImpact(m, in);
    const double u0 = std::fabs(in.vt - m.R * in.w), slide = 2.5 * m.mu * (1 + m.e) * in.vn / u0, inc = u0 / in.vn;
    std::printf("  %6.3f  %+9.4f %+9.4f %+9.4f | %+9.5f %+9.5f %+9.5f  %9.5f\n", inc, w.tangentialRatio, p.tangentialRatio,
                r.tangentialRatio, w.spin, p.spin, r.spin, slide);
    const double spinScale = 0.01 * std::min(slide, 3.5);  // the gross-sliding change, at most (7/2) |u| (rolling)
    EXPECT_NEAR(w.spin, r.spin, spinScale) << test << " |u|/vn " << inc << ": wall vs reference";
    EXPECT_NEAR(w.tangentialRatio, r.tangentialRatio, inc < 0.25 ? nearTol : farTol) << test << " |u|/vn " << inc << ": wall vs reference";
    if (inc >= 4) {
      EXPECT_NEAR(w.spin, slide, 0.005 * slide) << test << " |u|/vn " << inc << ": wall vs gross sliding";
    }
    if (inc <= 2) {
      EXPECT_NEAR(p.spin, w.spin, spinScale) << test << " |u|/vn " << inc << ": pair vs wall";
      EXPECT_NEAR(p.tangentialRatio, w.tangentialRatio, 0.01) << test << " |u|/vn " << inc << ": pair vs wall";
    } else {
      EXPECT_NEAR(p.spin, w.spin, 0.035 * w.spin) << test << " |u|/vn " << inc << ": pair vs wall (gross sliding)";
    }
  }
}

using Curve = std::vector<std::pair<double, double>>;

// A digitized figure kept in docs/accuracy (columns quantity, series, x, value): "quantity/series" -> (x, value).
std::map<std::string, Curve> digitized(const std::string& file) {
  std::map<std::string, Curve> curves;
  std::ifstream in(std::string(PFLOW_SOURCE_DIR) + "/docs/accuracy/" + file);
  EXPECT_TRUE(in) << "docs/accuracy/" << file;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("quantity,", 0) == 0) continue;
    std::stringstream row(line);
    std::string quantity, series, x, value;
    std::getline(row, quantity, ','), std::getline(row, series, ','), std::getline(row, x, ','), std::getline(row, value);
    curves[quantity + "/" + series].push_back({std::stod(x), std::stod(value)});
  }
  return curves;
}

// A test's table, written to PFLOW_CHUNG_OOI_DIR/name when that is set (bench/accuracy/run.sh draws it); else closed.
std::ofstream table(const std::string& name) {
  const char* dir = std::getenv("PFLOW_CHUNG_OOI_DIR");
  return dir ? std::ofstream(std::string(dir) + "/" + name) : std::ofstream();
}

TEST(MicroSlip, ChungOoiTest4ConstantSpeedAcrossIncidence) {
  std::vector<Incoming> cases;
  for (double deg : {2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 80.0}) {
    const double th = deg * std::numbers::pi / 180;
    cases.push_back({3.9 * std::cos(th), 3.9 * std::sin(th), 0});
  }
  check("Chung & Ooi test 4 (alumina, 3.9 m/s)", kAlumina, cases, 0.045, 0.005);
}

// Test 4 against Chung & Ooi's own published curve (their alumina DEM series, digitized from the paper's figure; the
// digitization kept in KratosMultiphysics/Kratos, DEMApplication basic_benchmarks/paper_data/benchmark4_graph1 and
// graph2.dat; read from docs/accuracy/chung_ooi_2011_test4_digitized.csv): the centre's tangential restitution
// e_t = v_t'/v_t and the spin after, at the digitized incidences. pflow's wall kernel at its default step. Tolerances:
// e_t to 0.02 (the figure's reading, about 0.005 in e_t and 0.1 degree in the angle, which the curve's steepest
// stretch, 0.05 a degree below 10 degrees, turns into 0.005, plus pflow's step, 0.01 in e_t at 5-10 degrees, and the
// two codes' different tangential histories); the spin to 4 % of the gross-sliding spin (2.5 mu (1 + e) v_n / R), the
// same reasoning. With PFLOW_CHUNG_OOI_DIR set, the table is written there (bench/accuracy/run.sh draws it).
TEST(MicroSlip, ChungOoiTest4AgainstTheirPublishedCurve) {
  const auto curves = digitized("chung_ooi_2011_test4_digitized.csv");
  const Curve& et = curves.at("et/Al_oxide_ref");
  const Curve& w = curves.at("spin_rad_per_s/Al_oxide_ref");  // digitized at other angles: interpolated (linear) to e_t's
  ASSERT_EQ(et.size(), 13u);
  ASSERT_EQ(w.size(), 13u);
  const auto interp = [](const Curve& c, double x) {
    std::size_t k = 1;
    while (k + 1 < c.size() && c[k].first < x) ++k;
    const double t = (x - c[k - 1].first) / (c[k].first - c[k - 1].first);
    return c[k - 1].second + t * (c[k].second - c[k - 1].second);
  };
  std::ofstream csv = table("chung_ooi_test4_pflow.csv");
  if (csv.is_open()) {
    csv << "# pflow wall kernel at its default step (micro_slip_test, MicroSlip.ChungOoiTest4AgainstTheirPublishedCurve, "
           "CPU): alumina sphere R 2.5 mm, 3.9 m/s, mu 0.092, e 0.98\n"
           "incident_angle_deg,et_pflow,et_chung_ooi,spin_rad_per_s_pflow,spin_rad_per_s_chung_ooi_interpolated\n";
  }
  const Material& m = kAlumina;
  std::printf("Chung & Ooi test 4 against their figure\n  deg    e_t: pflow   theirs |  w' [rad/s]: pflow  theirs\n");
  for (const auto& [deg, theirs] : et) {
    const double th = deg * std::numbers::pi / 180, vn = 3.9 * std::cos(th), vt = 3.9 * std::sin(th);
    const Rebound r = pflowImpact(m, false, {vn, vt, 0});
    const double e_t = r.tangentialRatio + r.spin, spin = r.spin * vt / m.R, theirSpin = interp(w, deg);
    const double slide = 2.5 * m.mu * (1 + m.e) * vn / m.R;
    std::printf("  %5.2f  %8.4f %8.4f | %8.1f %8.1f\n", deg, e_t, theirs, spin, theirSpin);
    if (csv.is_open()) csv << deg << "," << e_t << "," << theirs << "," << spin << "," << theirSpin << "\n";
    EXPECT_NEAR(e_t, theirs, 0.02) << deg << " degrees";
    EXPECT_NEAR(spin, theirSpin, 0.04 * slide) << deg << " degrees";
  }
}

TEST(MicroSlip, ChungOoiTest5ConstantNormalSpeedTangentialVelocities) {
  std::vector<Incoming> cases;
  for (double vt : {0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6}) cases.push_back({0.2, vt, 0});
  check("Chung & Ooi test 5 (aluminium alloy, v_n = 0.2 m/s)", kAluminium, cases, 0.015, 0.015);
}

TEST(MicroSlip, ChungOoiTest6ConstantNormalSpeedSpins) {
  std::vector<Incoming> cases;
  for (double u : {0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6}) cases.push_back({0.2, 0, -u / kAluminium.R});  // backspin: u = +R |w|
  check("Chung & Ooi test 6 (aluminium alloy, v_n = 0.2 m/s, spinning)", kAluminium, cases, 0.015, 0.015);
}

// Test 6 against Chung & Ooi's published curves (digitized as test 4's, benchmark6_graph1.dat; read from
// docs/accuracy/chung_ooi_2011_test6_digitized.csv): an aluminium-alloy and a nylon sphere spinning with no tangential
// velocity, at a normal 0.2 m/s, mu 0.4, e 0.5. Their axes: x = 3.5 mu (1 + e) v_n / u against beta = -u'/u, u the
// contact point's tangential velocity (x < 1: gross sliding, beta = x - 1 for rigid bodies whatever the tangential
// law). Held: gross sliding (x <= 1) within 0.02 (the figure's reading). Printed and tabled, not held: x > 1, where the
// tangential spring and its dashpot decide and the two curves part (docs/accuracy.md, "Micro-slip": pflow's tangential
// dashpot returns the contact point's motion at small incidence as converged test 5-6 do above, beta -0.04 at x = 24
// against their -0.34 for the alloy; no tangential dashpot strength alone reproduces their curve).
TEST(MicroSlip, ChungOoiTest6AgainstTheirPublishedCurve) {
  const auto curves = digitized("chung_ooi_2011_test6_digitized.csv");
  std::ofstream csv = table("chung_ooi_test6_pflow.csv");
  if (csv.is_open()) {
    csv << "# pflow wall kernel at its default step (micro_slip_test, MicroSlip.ChungOoiTest6AgainstTheirPublishedCurve, "
           "CPU): spheres R 0.1 m spinning at a normal 0.2 m/s, mu 0.4, e 0.5\n"
           "series,x,beta_pflow,beta_chung_ooi,tan_recoil_pflow,beta_reference,beta_reference_half_tangential_dashpot,"
           "beta_reference_no_tangential_dashpot\n";
  }
  for (const auto& [series, m] : {std::pair{std::string("Al_alloy_ref"), kAluminium}, std::pair{std::string("nylon_ref"), kNylon}}) {
    const Curve& beta = curves.at("beta/" + series);
    ASSERT_EQ(beta.size(), 17u) << series;
    std::printf("Chung & Ooi test 6 (%s) against their figure\n      x   beta: pflow   theirs | converged, tangential "
                "dashpot x1    x0.5      x0\n", series.c_str());
    for (const auto& [x, theirs] : beta) {
      const double vn = 0.2, u = 3.5 * m.mu * (1 + m.e) * vn / x;
      const Rebound r = pflowImpact(m, false, {vn, 0, -u / m.R});
      const double b = -r.tangentialRatio, tanRecoil = r.tangentialRatio * u / (m.e * vn);
      double ref[3];
      for (int k = 0; k < 3; ++k) ref[k] = -referenceImpact(m, {vn, 0, -u / m.R}, 1 - 0.5 * k).tangentialRatio;
      std::printf("  %6.3f  %+8.4f %+8.4f | %+8.4f %+8.4f %+8.4f\n", x, b, theirs, ref[0], ref[1], ref[2]);
      if (csv.is_open()) {
        csv << series << "," << x << "," << b << "," << theirs << "," << tanRecoil << "," << ref[0] << "," << ref[1] << "," << ref[2] << "\n";
      }
      EXPECT_NEAR(b, ref[0], 0.015) << series << " x " << x << ": pflow's step against its converged law";
      if (x <= 1) {
        EXPECT_NEAR(b, theirs, 0.02) << series << " x " << x;
      }
    }
  }
}

// Where in a step a grazing, strongly damped contact begins must not decide its rebound: test 5's smallest incidences
// (|u|/v_n = 0.1 and 0.25, e = 0.5) begun at eight points of a step, at the default step. Each within 0.015 of the
// converged model and within 0.012 of each other (measured: 0.042-0.051 and 0.042-0.044 against 0.039 and 0.033).
// Before the fix a contact beginning in the last 60 % of a step slid from its first step (its normal dashpot counted
// only the part of the step in contact, its tangential one the whole step) and then kept sliding: up to 0.23.
TEST(MicroSlip, GrazingReboundDoesNotDependOnWhereInAStepTheContactBegan) {
  for (double vt : {0.02, 0.05}) {
    const Incoming in{0.2, vt, 0};
    const double ref = referenceImpact(kAluminium, in).tangentialRatio;
    double lo = 1e9, hi = -1e9;
    for (int k = 0; k < 8; ++k) {
      const double r = pflowImpact(kAluminium, false, in, (k + 0.01) / 8).tangentialRatio;
      EXPECT_NEAR(r, ref, 0.015) << "vt " << vt << " phase " << (k + 0.01) / 8;
      lo = std::min(lo, r), hi = std::max(hi, r);
    }
    std::printf("|u|/vn %.2f: u'/u %.4f .. %.4f over the phase, converged %.4f\n", vt / 0.2, lo, hi, ref);
    EXPECT_LT(hi - lo, 0.012) << "vt " << vt;
  }
}

// Two spheres (radii Ri below, Rj above, the same material) meeting along z: the lower one moving up at vn / 2 with
// tangential velocity vt / 2 and spin wi about y, the upper one the opposite velocity and spin wj. pflow's pair kernel
// against an independent integration of the same law for the two bodies (1/50 of pflow's step). Returned: u'/u for
// the relative contact-point velocity u = (v_i,x + l_i w_i) - (v_j,x - l_j w_j), and each sphere's spin change
// (w' - w) R / |u|.
struct PairRebound {
  double tangentialRatio = 0, spinI = 0, spinJ = 0;
};
struct PairIncoming {
  double vn, vt, wi, wj;
};

PairRebound pflowPair(const Material& m, double Ri, double Rj, PairIncoming in) {
  const double gap = 4e-6;
  RunConfig c;
  c.materials = {material("sphere", m.E, m.nu, m.rho, m.e, m.mu)};
  addParticle(c, {0, 0, -Ri - gap / 2}, Ri, 0, {0.5 * in.vt, 0, 0.5 * in.vn}, {0, in.wi, 0});
  addParticle(c, {0, 0, Rj + gap / 2}, Rj, 0, {-0.5 * in.vt, 0, -0.5 * in.vn}, {0, in.wj, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1e3;
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return {};
  const double mi = sphereMass(Ri, m.rho), mj = sphereMass(Rj, m.rho);
  const double tc = hertzImpact(m.E / (2 * (1 - m.nu * m.nu)), Ri * Rj / (Ri + Rj), mi * mj / (mi + mj), in.vn).contactTime;
  EXPECT_TRUE(sim.value()->runUntil(3 * tc + gap / in.vn).isOk());
  const auto snap = sim.value()->snapshot({"velocity", "angular_velocity", "id"});
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const Vec3d* w = snap.find("angular_velocity")->as<Vec3d>();
  const Gid* id = snap.find("id")->as<Gid>();
  const std::size_t i = id[0] == 0 ? 0 : 1, j = 1 - i;
  const double u0 = in.vt + Ri * in.wi + Rj * in.wj;
  const double u = (v[i].x + Ri * w[i].y) - (v[j].x - Rj * w[j].y);
  return {u / u0, (w[i].y - in.wi) * Ri / std::fabs(u0), (w[j].y - in.wj) * Rj / std::fabs(u0)};
}

PairRebound referencePair(const Material& m, double Ri, double Rj, PairIncoming in) {
  const double Es = m.E / (2 * (1 - m.nu * m.nu)), Gs = m.E / (2 * (1 + m.nu)) / (2 * (2 - m.nu)), Rs = Ri * Rj / (Ri + Rj);
  const double mi = sphereMass(Ri, m.rho), mj = sphereMass(Rj, m.rho), ms = mi * mj / (mi + mj);
  const double Ii = 0.4 * mi * Ri * Ri, Ij = 0.4 * mj * Rj * Rj;
  const double c = compute::dampingCoeffForRestitution(m.e), ratio = std::sqrt(4 * Gs / Es);
  const double dt = 0.2 * compute::rayleighTime(std::min(Ri, Rj), m.rho, m.E, m.nu) / 50;
  double gapZ = 0, vzi = 0.5 * in.vn, vzj = -0.5 * in.vn, vxi = 0.5 * in.vt, vxj = -0.5 * in.vt, wi = in.wi, wj = in.wj, xi = 0;
  double fn = 0, ft = 0, li = Ri, lj = Rj;  // fn pushes them apart; ft acts on i along x (j gets -ft)
  auto forces = [&](double h) {
    fn = ft = 0;
    const double d = -gapZ;  // overlap: the gap between the surfaces, negative
    if (d <= 0) {
      xi = 0;
      return;
    }
    const double a = std::sqrt(Rs * d), damp = c * std::sqrt(2 * Es * a * ms), vn = vzi - vzj;
    fn = std::max(0.0, 4.0 / 3.0 * Es * a * d + damp * vn);
    li = Ri - 0.5 * d, lj = Rj - 0.5 * d;
    const double u = (vxi + li * wi) - (vxj - lj * wj), kt = 8 * Gs * a;
    xi += h * u;
    ft = -kt * xi - damp * ratio * u;
    if (std::fabs(ft) > m.mu * fn) {
      ft = ft > 0 ? m.mu * fn : -m.mu * fn;
      xi = -ft / kt;
    }
  };
  auto kick = [&](double h) {
    vzi -= h * fn / mi, vzj += h * fn / mj;
    vxi += h * ft / mi, vxj -= h * ft / mj;
    wi += h * li * ft / Ii, wj += h * lj * ft / Ij;  // both spins: (l z) x (F_t x) and (-l z) x (-F_t x)
  };
  bool touched = false;
  for (long k = 0; k < 100000000; ++k) {
    kick(0.5 * dt);
    gapZ -= dt * (vzi - vzj);
    forces(dt);
    kick(0.5 * dt);
    touched |= gapZ < 0;
    if (touched && gapZ > 0) break;
  }
  const double u0 = in.vt + Ri * in.wi + Rj * in.wj;
  const double u = (vxi + Ri * wi) - (vxj - Rj * wj);
  return {u / u0, (wi - in.wi) * Ri / std::fabs(u0), (wj - in.wj) * Rj / std::fabs(u0)};
}

// pflow's pair kernel against the two-body reference: u'/u to 0.01 from the incidence |u| / v_n = 0.5 on and to 0.015
// below it (the default step's first-order error at grazing incidence, as tests 5 and 6), the spin changes to 1 % of
// their largest.
void checkPairs(const char* test, const Material& m, double Ri, double Rj, const std::vector<PairIncoming>& cases) {
  std::printf("%s\n  |u|/vn  u'/u: pflow  reference | spin change i: pflow  reference | j: pflow  reference\n", test);
  double scale = 0;
  std::vector<std::pair<PairRebound, PairRebound>> out;
  for (const PairIncoming& in : cases) {
    out.push_back({pflowPair(m, Ri, Rj, in), referencePair(m, Ri, Rj, in)});
    scale = std::max({scale, std::fabs(out.back().second.spinI), std::fabs(out.back().second.spinJ)});
  }
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const PairIncoming& in = cases[k];
    const auto& [p, r] = out[k];
    const double inc = std::fabs(in.vt + Ri * in.wi + Rj * in.wj) / in.vn;
    std::printf("  %6.3f  %+9.4f %+9.4f | %+9.5f %+9.5f | %+9.5f %+9.5f\n", inc, p.tangentialRatio, r.tangentialRatio, p.spinI,
                r.spinI, p.spinJ, r.spinJ);
    EXPECT_NEAR(p.tangentialRatio, r.tangentialRatio, inc < 0.5 ? 0.015 : 0.01) << test << " |u|/vn " << inc;
    EXPECT_NEAR(p.spinI, r.spinI, 0.01 * scale) << test << " |u|/vn " << inc;
    EXPECT_NEAR(p.spinJ, r.spinJ, 0.01 * scale) << test << " |u|/vn " << inc;
  }
}

// Chung & Ooi test 7: two identical spheres at a normal 0.2 m/s, spinning (the same spin on both: their contact points
// move apart at 2 R w).
TEST(MicroSlip, ChungOoiTest7IdenticalSpheresSpinning) {
  std::vector<PairIncoming> cases;
  for (double u : {0.02, 0.1, 0.2, 0.4, 0.8, 1.6}) cases.push_back({0.2, 0, 0.5 * u / kAluminium.R, 0.5 * u / kAluminium.R});
  checkPairs("Chung & Ooi test 7 (aluminium alloy spheres, R = 0.1 m, spinning)", kAluminium, kAluminium.R, kAluminium.R, cases);
}

// Chung & Ooi test 8: spheres of radii 0.1 and 0.05 m at a normal 0.2 m/s with tangential velocities.
TEST(MicroSlip, ChungOoiTest8UnequalSpheresTangentialVelocities) {
  std::vector<PairIncoming> cases;
  for (double vt : {0.02, 0.1, 0.2, 0.4, 0.8, 1.6}) cases.push_back({0.2, vt, 0, 0});
  checkPairs("Chung & Ooi test 8 (aluminium alloy spheres, R = 0.1 and 0.05 m)", kAluminium, kAluminium.R, 0.5 * kAluminium.R, cases);
}

}  // namespace
}  // namespace pflow::test
