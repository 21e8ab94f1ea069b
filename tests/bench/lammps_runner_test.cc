// Tests of the LAMMPS side of the settled-bed benchmark. Tests that run LAMMPS skip when `lmp` is not installed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "bench/LammpsRunner.h"

namespace pflow::bench {
namespace {

#define SKIP_WITHOUT_LAMMPS()                                          \
  do {                                                                 \
    if (!findLammps()) GTEST_SKIP() << "lmp (LAMMPS) not on PATH";     \
  } while (0)

LammpsOptions lammpsOptions(int ranks = 1) {
  LammpsOptions o;
  o.lmp = *findLammps();
  o.ranks = ranks;
  return o;
}

// nx*ny*nz spheres of diameter d on a lattice of spacing 1.05 d with a small random shift, in a box of 5 walls.
LammpsBed latticeBed(int nx, int ny, int nz, double d = 1e-3) {
  LammpsBed b;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> shift(-0.02 * d, 0.02 * d);
  const double a = 1.05 * d;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        b.position.push_back({(i + 0.5) * a + shift(rng), (j + 0.5) * a + shift(rng), (k + 0.5) * a + shift(rng)});
        b.radius.push_back(0.5 * d);
      }
  b.boxLo = {0, 0, 0};
  b.boxHi = {nx * a, ny * a, nz * a};
  b.dt = 5e-6;
  b.skin = 0.1 * d;
  b.steps = 200;
  return b;
}

// --- restitution mapping (no LAMMPS needed) ---

TEST(LammpsTsuji, ElasticImpactConservesSpeed) {
  EXPECT_NEAR(hertzTsujiRestitution(0.0, false), 1.0, 1e-6);
  EXPECT_NEAR(hertzTsujiRestitution(0.0, true), 1.0, 1e-6);
}

TEST(LammpsTsuji, InputForHalfMatchesBenchmarkNote) {
  // benchmarks.md: this LAMMPS version needs `damping tsuji 0.367` for a measured restitution of 0.5.
  EXPECT_NEAR(lammpsTsujiInputFor(0.5, false), 0.367, 0.002);
}

TEST(LammpsTsuji, PolynomialHoldsWithSqrt2MoreDamping) {
  // The polynomial alpha(e) reproduces e once the damping is sqrt(2) times what LAMMPS applies.
  for (double e : {0.3, 0.5, 0.7, 0.9}) EXPECT_NEAR(hertzTsujiRestitution(std::sqrt(2.0) * tsujiAlpha(e), false), e, 0.003);
}

TEST(LammpsTsuji, MappingInvertsTheEquationOfMotion) {
  for (bool clipped : {false, true})
    for (double e : {0.3, 0.5, 0.8, 0.95}) {
      const double in = lammpsTsujiInputFor(e, clipped);
      ASSERT_TRUE(in >= 0 && in <= 1) << e;
      EXPECT_LT(in, e);  // LAMMPS damps too little, so the input is lower than the target
      EXPECT_NEAR(hertzTsujiRestitution(tsujiAlpha(in), clipped), e, 1e-6);
    }
  EXPECT_TRUE(std::isnan(lammpsTsujiInputFor(0.1, false)));  // reachable: >= 0.114 unclipped, >= 0.263 clipped
  EXPECT_TRUE(std::isnan(lammpsTsujiInputFor(0.25, true)));
  EXPECT_FALSE(std::isnan(lammpsTsujiInputFor(0.2, false)));
  EXPECT_TRUE(std::isnan(lammpsTsujiInputFor(1.5, false)));
  EXPECT_EQ(lammpsTsujiInputFor(1.0, false), 1.0);
}

TEST(LammpsTsuji, StepSizeConverged) {
  // The public function uses h = 5e-4; compare with the polynomial's own value at a finer step via the inverse.
  const double e1 = hertzTsujiRestitution(0.3407, false);
  EXPECT_NEAR(e1, 0.6161, 5e-4);  // alpha(0.5) = 0.3407 realises 0.616 in LAMMPS (unclipped)
}

// --- bed and script (no LAMMPS needed) ---

TEST(LammpsBedTest, ValidationCatchesBadBeds) {
  LammpsBed b = latticeBed(2, 2, 2);
  EXPECT_TRUE(validateBed(b).isOk());
  LammpsBed empty;
  EXPECT_FALSE(validateBed(empty).isOk());
  LammpsBed outside = b;
  outside.position[3].x = -1e-4;
  EXPECT_FALSE(validateBed(outside).isOk());
  LammpsBed sizes = b;
  sizes.radius.pop_back();
  EXPECT_FALSE(validateBed(sizes).isOk());
  LammpsBed lowE = b;
  lowE.restitution = 0.01;
  EXPECT_FALSE(validateBed(lowE).isOk());
}

TEST(LammpsBedTest, ScriptHasTheModel) {
  LammpsBed b = latticeBed(2, 2, 2);
  const std::string s = lammpsInputScript(b, "bed.data");
  EXPECT_NE(s.find("units si\n"), std::string::npos);
  EXPECT_NE(s.find("boundary f f fm\n"), std::string::npos);
  EXPECT_NE(s.find("pair_coeff * * hertz/material 1e+07 0.2964"), std::string::npos);
  EXPECT_NE(s.find("tangential mindlin NULL 1 0.5 damping tsuji limit_damping"), std::string::npos);
  EXPECT_NE(s.find("xplane 0 0.002"), std::string::npos);
  EXPECT_NE(s.find("zplane 0 NULL"), std::string::npos);
  EXPECT_NE(s.find("fix gravity all gravity 9.81 vector 0 0 -1\n"), std::string::npos);
  EXPECT_NE(s.find("neigh_modify delay 0 every 1 check yes\n"), std::string::npos);
  EXPECT_NE(s.find("run 200\n"), std::string::npos);
  EXPECT_EQ(s.find("rolling"), std::string::npos);
  b.rollingFriction = 0.1;
  EXPECT_NE(lammpsInputScript(b, "bed.data").find(" rolling sds "), std::string::npos);
}

// --- LAMMPS runs ---

TEST(LammpsRun, DataFileRoundTrip) {
  SKIP_WITHOUT_LAMMPS();
  LammpsBed b = latticeBed(2, 2, 2);
  b.velocity.assign(8, {0.1, -0.2, 0.3});
  b.angularVelocity.assign(8, {1.5, -2.5, 3.5});
  const auto dir = std::filesystem::temp_directory_path() / ("pflow-lmp-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string data = (dir / "bed.data").string();
  ASSERT_TRUE(writeLammpsData(b, data).isOk());
  const std::string script = "units si\natom_style sphere\natom_modify map array\nboundary f f fm\n"
                             "read_data " + data + "\n"
                             "compute wy all property/atom omegay\n"
                             "variable m equal mass[5]\nvariable wy equal c_wy[5]\nvariable vz equal vz[5]\n"
                             "variable x equal x[5]\nthermo_style custom step v_wy\nrun 0\n"
                             "print \"CHECK ${m} ${wy} ${vz} ${x}\"\n";
  auto log = runLammpsInput(script, lammpsOptions());
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(log.isOk()) << log.status().toString();
  const auto at = log->find("\nCHECK ");
  ASSERT_NE(at, std::string::npos) << *log;
  double m = 0, wy = 0, vz = 0, x = 0;
  ASSERT_EQ(std::sscanf(log->c_str() + at, "\nCHECK %lf %lf %lf %lf", &m, &wy, &vz, &x), 4);
  EXPECT_NEAR(m, 2500 * 4.0 / 3.0 * M_PI * 0.125e-9, 1e-15);
  EXPECT_DOUBLE_EQ(wy, -2.5);
  EXPECT_DOUBLE_EQ(vz, 0.3);
  EXPECT_DOUBLE_EQ(x, b.position[4].x);
}

TEST(LammpsRun, TinyBedRuns) {
  SKIP_WITHOUT_LAMMPS();
  const LammpsBed b = latticeBed(4, 4, 4);
  auto r = runLammps(b, lammpsOptions());
  ASSERT_TRUE(r.isOk()) << r.status().toString();
  EXPECT_EQ(r->atoms, 64);
  EXPECT_EQ(r->steps, 200);
  EXPECT_EQ(r->ranks, 1);
  EXPECT_GT(r->loopSeconds, 0);
  EXPECT_GT(r->particleStepsPerSecond, 0);
  EXPECT_EQ(r->dangerousBuilds, 0);
  EXPECT_TRUE(r->logPath.empty());  // temporary directory removed
  EXPECT_FALSE(r->lammpsVersion.empty());
  EXPECT_NEAR(r->tsujiInput, lammpsTsujiInputFor(0.5, true), 1e-12);
}

TEST(LammpsRun, TwoRanks) {
  SKIP_WITHOUT_LAMMPS();
  if (::access("/usr/bin/mpirun", X_OK) != 0 && std::system("command -v mpirun >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "mpirun not found";
  const LammpsBed b = latticeBed(6, 4, 3);
  auto r = runLammps(b, lammpsOptions(2));
  ASSERT_TRUE(r.isOk()) << r.status().toString();
  EXPECT_EQ(r->atoms, 72);
  EXPECT_EQ(r->ranks, 2);
  EXPECT_GT(r->particleStepsPerSecond, 0);
}

TEST(LammpsRun, FailureNamesCommandAndLog) {
  SKIP_WITHOUT_LAMMPS();
  auto log = runLammpsInput("units si\nthis_is_not_a_command\n", lammpsOptions());
  ASSERT_FALSE(log.isOk());
  const std::string& m = log.status().message();
  EXPECT_NE(m.find("-in in.lammps"), std::string::npos) << m;
  EXPECT_NE(m.find("log.lammps"), std::string::npos) << m;
  EXPECT_NE(m.find("ERROR"), std::string::npos) << m;
  // The directory is kept for diagnosis; remove it.
  const auto cd = m.find("cd '");
  ASSERT_NE(cd, std::string::npos);
  const auto end = m.find('\'', cd + 4);
  std::filesystem::remove_all(m.substr(cd + 4, end - cd - 4));
}

// The runner's walls act as a wall of the spheres' own material: E* = E/(2(1-nu^2)), k_t = 8 G* sqrt(R delta)
// (this LAMMPS's fix wall/gran alone would use E/(2(1-nu)) and a wrong derived k_t).
TEST(LammpsRun, WallActsAsSameMaterial) {
  SKIP_WITHOUT_LAMMPS();
  const double r = 0.5e-3, delta = 1e-5, u = 0.01, dt = 1e-6, E = 1e7, nu = 0.3;
  LammpsBed b;
  b.position = {{2e-3, 2e-3, r - delta}};
  b.radius = {r};
  b.velocity = {{u, 0, 0}};
  b.boxHi = {4e-3, 4e-3, 4e-3};
  b.gravity = {0, 0, 0};
  b.youngsModulus = E;
  b.poissonRatio = nu;
  b.friction = 100;  // no sliding
  b.tangentialDampingRatio = 0;
  b.dt = dt;
  b.steps = 10;
  const auto dir = std::filesystem::temp_directory_path() / ("pflow-lmp-wall-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string data = (dir / "bed.data").string();
  ASSERT_TRUE(writeLammpsData(b, data).isOk());
  // The bed's own script with the sphere held in place (no integrator): the tangential spring grows by u dt a step.
  std::string script = lammpsInputScript(b, data);
  script.replace(script.find("fix integrate all nve/sphere\n"), 29, "");
  script.replace(script.find("atom_style sphere\n"), 18, "atom_style sphere\natom_modify map array\n");
  script += "variable fx equal fx[1]\nvariable fz equal fz[1]\nprint \"FORCE ${fx} ${fz}\"\n";
  auto log = runLammpsInput(script, lammpsOptions());
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(log.isOk()) << log.status().toString();
  const auto at = log->find("\nFORCE ");
  ASSERT_NE(at, std::string::npos) << *log;
  double fx = 0, fz = 0;
  ASSERT_EQ(std::sscanf(log->c_str() + at, "\nFORCE %lf %lf", &fx, &fz), 2);
  const double eStar = E / (2 * (1 - nu * nu)), gStar = E / (2 * (1 + nu)) / (2 * (2 - nu));
  EXPECT_NEAR(fz, 4.0 / 3.0 * eStar * std::sqrt(r) * std::pow(delta, 1.5), 1e-9 * fz);
  EXPECT_NEAR(fx, -8 * gStar * std::sqrt(r * delta) * u * dt * 10, 1e-6 * std::abs(fx));
}

// The realised restitution in LAMMPS equals the requested one (within 1 %) once the input is mapped.
TEST(LammpsRun, RealisedRestitutionMatches) {
  SKIP_WITHOUT_LAMMPS();
  struct Case { double e; bool wall; bool clipped; };
  for (const Case c : {Case{0.5, true, false}, Case{0.5, false, false}, Case{0.5, true, true}, Case{0.3, true, false},
                       Case{0.8, true, false}, Case{0.8, false, true}}) {
    ImpactSpec sp;
    sp.onWall = c.wall;
    sp.clipNormalForce = c.clipped;
    auto e = measureLammpsRestitution(lammpsTsujiInputFor(c.e, c.clipped), sp, lammpsOptions());
    ASSERT_TRUE(e.isOk()) << e.status().toString();
    std::printf("  target e %.2f %-6s %-9s -> tsuji %.5f -> LAMMPS e %.5f\n", c.e, c.wall ? "wall" : "pair",
                c.clipped ? "clipped" : "unclipped", lammpsTsujiInputFor(c.e, c.clipped), *e);
    EXPECT_NEAR(*e, c.e, 0.01 * c.e) << "e=" << c.e << " wall=" << c.wall << " clipped=" << c.clipped;
  }
  // The benchmark's note: input 0.367 realises 0.5 (unclipped).
  ImpactSpec sp;
  auto e = measureLammpsRestitution(0.367, sp, lammpsOptions());
  ASSERT_TRUE(e.isOk()) << e.status().toString();
  std::printf("  tsuji 0.367 (unclipped, wall) -> LAMMPS e %.5f\n", *e);
  EXPECT_NEAR(*e, 0.5, 0.005);
}

}  // namespace
}  // namespace pflow::bench
