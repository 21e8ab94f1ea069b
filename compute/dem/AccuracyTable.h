// The accuracy study's table (docs/accuracy/study.csv, embedded at build time) and the cheapest settings
// it shows to meet a scene's accuracy target (simulation.accuracy). Plain host code.
#pragma once
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/Status.h"

namespace pflow::compute {

// One line of the study: a problem run at one group of settings, the quantity measured and its relative error.
struct AccuracyRow {
  std::string problem, quantity, reference, executor, precision;  // precision: "float" | "double"
  double dtFraction = 0, softening = 0, skinFraction = 0;
  std::int64_t rebuildInterval = 0;
  double value = 0, error = 0;  // error: relative to the reference
  double wallSecondsPerSimSecond = 0;
  std::int64_t steps = 0;
  std::string status;  // "ok" or a failure mode
};

// The cheapest settings (least wall time per simulated second, summed over the problems) on one executor
// whose worst error over every problem that measures the quantity is within the tolerance.
struct AccuracyProposal {
  std::string executor, precision;
  double dtFraction = 0, softening = 0, skinFraction = 0;
  std::int64_t rebuildInterval = 0;
  double worstError = 0;  // max over the problems
  double cost = 0;        // wall s per simulated s, summed over the problems
  std::vector<std::string> problems;
  std::string text() const;  // "cuda: float, dt_fraction 0.2, softening 1, skin 0.1, ... (worst error 0.4 % over ...)"
};

class AccuracyTable {
 public:
  // The CSV's columns, in this order (the header must name exactly these).
  static constexpr std::string_view kColumns =
      "problem,quantity,reference,executor,precision,dt_fraction,softening,skin_fraction,rebuild_interval,value,error,"
      "wall_s_per_sim_s,steps,status";

  // Every malformed line is an error naming `source`, the line and the column.
  static Result<AccuracyTable> parse(std::string_view csv, const std::string& source = "study.csv");
  // The table embedded at build time (empty when docs/accuracy/study.csv did not exist, or did not parse).
  static const AccuracyTable& builtIn();

  bool empty() const { return m_rows.empty(); }
  const std::vector<AccuracyRow>& rows() const { return m_rows; }
  // The distinct quantity names, sorted.
  std::vector<std::string> quantities() const;
  // One proposal per executor that can meet the target (sorted by executor); empty when none can. An error
  // naming the known quantities when `quantity` is not among them.
  Result<std::vector<AccuracyProposal>> propose(const std::string& quantity, double tolerance) const;
  // Whether `precision` on `executor` met the target at full stiffness (softening 1) with automatic rebuilds
  // at some dt_fraction >= minDtFraction, over every problem measuring the quantity: since the error grows
  // with dt, the target then holds at a scene's own dt_fraction too. False for an unknown quantity.
  bool meetsAt(const std::string& quantity, double tolerance, const std::string& executor, const std::string& precision,
               double minDtFraction) const;

 private:
  // Every settings group (executor, precision, dt, softening, skin, rebuild) measured on every problem that
  // measures the quantity, with its worst error and summed cost, that meets the tolerance.
  std::vector<AccuracyProposal> meeting(const std::string& quantity, double tolerance) const;
  std::vector<AccuracyRow> m_rows;
};

}  // namespace pflow::compute
