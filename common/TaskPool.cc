#include "common/TaskPool.h"

#include <algorithm>

namespace pflow {

TaskPool::TaskPool(int threads) {
  for (int i = 0; i < std::max(1, threads); ++i) m_threads.emplace_back([this] { run(); });
}

TaskPool::~TaskPool() {
  {
    std::lock_guard lock(m_mu);
    m_stop = true;
  }
  m_cv.notify_all();
  for (std::thread& t : m_threads) t.join();
}

void TaskPool::post(std::function<void()> task) {
  {
    std::lock_guard lock(m_mu);
    m_tasks.push_back(std::move(task));
  }
  m_cv.notify_one();
}

void TaskPool::run() {
  for (;;) {
    std::function<void()> task;
    {
      std::unique_lock lock(m_mu);
      m_cv.wait(lock, [this] { return m_stop || !m_tasks.empty(); });
      if (m_tasks.empty()) return;  // stopping, nothing left
      task = std::move(m_tasks.front());
      m_tasks.pop_front();
    }
    task();
  }
}

}  // namespace pflow
