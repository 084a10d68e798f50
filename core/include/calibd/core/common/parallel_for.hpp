#pragma once
/// \file
/// The one way core shares independent tasks over threads (the engine's quality re-solves, the
/// direct optimiser's board-pose refinement, the LiDAR detector's reference descriptors). Tasks
/// are handed out in order, one at a time, to `threads` workers: the calling thread and
/// threads - 1 started for the call and joined before it returns. Written here rather than taken
/// from std::execution::par, whose libstdc++ implementation needs TBB at run time and gives no
/// worker index for per-worker scratch.

#include <functional>

namespace calibd {

/// Runs body(worker, task) for every task in [0, tasks) on min(threads, tasks) workers (at least
/// one: the caller); `worker` in [0, threads) indexes per-worker scratch, worker 0 being the
/// calling thread. Returns when every task has run.
void ParallelFor(int threads, int tasks, const std::function<void(int worker, int task)>& body);

}  // namespace calibd
