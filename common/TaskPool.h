// A fixed set of threads running posted tasks in order of posting; the destructor runs what is queued, then joins.
// Services use it to keep blocking work (SQLite, HDF5, calls to other services) off gRPC's callback threads.
#pragma once
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace pflow {

class TaskPool {
 public:
  explicit TaskPool(int threads);
  ~TaskPool();
  TaskPool(const TaskPool&) = delete;
  TaskPool& operator=(const TaskPool&) = delete;
  void post(std::function<void()> task);

 private:
  void run();
  std::mutex m_mu;
  std::condition_variable m_cv;
  std::deque<std::function<void()>> m_tasks;
  bool m_stop = false;
  std::vector<std::thread> m_threads;
};

}  // namespace pflow
