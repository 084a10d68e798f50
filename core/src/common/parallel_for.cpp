#include "calibd/core/common/parallel_for.hpp"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace calibd {

void ParallelFor(int threads, int tasks, const std::function<void(int worker, int task)>& body) {
  if (tasks <= 0) return;
  const int workers = std::clamp(threads, 1, tasks);
  std::atomic<int> next{0};
  auto work = [&](int worker) {
    for (int task = next++; task < tasks; task = next++) body(worker, task);
  };
  std::vector<std::thread> started;
  started.reserve(static_cast<size_t>(workers - 1));
  for (int w = 1; w < workers; ++w) started.emplace_back(work, w);
  work(0);
  for (std::thread& t : started) t.join();
}

}  // namespace calibd
