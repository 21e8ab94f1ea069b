// When a run takes its next checkpoint (pflow run's RunCheckpoints, the worker's JobCheckpoints): after every
// `everySteps` steps, at every multiple of `everySeconds` of simulated time (the scene's output.checkpoint_interval),
// or after `wallSeconds` of wall clock since the last one, whichever comes first; the caller takes it at the first
// step that ended with a cell sort from then on (where a simulation's state() may be taken). 0 turns a criterion off.
#pragma once
#include <chrono>
#include <cstdint>

namespace pflow::compute {

class CheckpointSchedule {
 public:
  CheckpointSchedule() = default;
  // `step`, `time`: where the run starts (its resume point, or 0).
  CheckpointSchedule(std::int64_t everySteps, double everySeconds, double wallSeconds, std::int64_t step, double time)
      : m_everySteps(everySteps), m_everySeconds(everySeconds), m_wallSeconds(wallSeconds), m_lastStep(step),
        m_lastWall(std::chrono::steady_clock::now()) {
    m_nextTime = everySeconds;
    while (everySeconds > 0 && m_nextTime <= time) m_nextTime += everySeconds;
  }
  bool on() const { return m_everySteps > 0 || m_everySeconds > 0 || m_wallSeconds > 0; }
  bool due(std::int64_t step, double time) const {
    const bool bySteps = m_everySteps > 0 && step - m_lastStep >= m_everySteps;
    const bool byTime = m_everySeconds > 0 && time >= m_nextTime;
    const bool byWall = m_wallSeconds > 0 &&
                        std::chrono::duration<double>(std::chrono::steady_clock::now() - m_lastWall).count() >= m_wallSeconds;
    return bySteps || byTime || byWall;
  }
  void taken(std::int64_t step, double time) {
    m_lastStep = step;
    m_lastWall = std::chrono::steady_clock::now();
    while (m_everySeconds > 0 && m_nextTime <= time) m_nextTime += m_everySeconds;
  }

 private:
  std::int64_t m_everySteps = 0;
  double m_everySeconds = 0, m_wallSeconds = 0;
  std::int64_t m_lastStep = 0;
  double m_nextTime = 0;
  std::chrono::steady_clock::time_point m_lastWall;
};

}  // namespace pflow::compute
