#include "calibd/agent/solve_runner.hpp"

#include "calibd/agent/thread_nice.hpp"

namespace calibd {

SolveRunner::~SolveRunner() {
  if (thread_.joinable()) thread_.join();
}

void SolveRunner::Start(int session, const CalibConfig& calib,
                        const SessionObservations& observations, const RangeImage& projection,
                        const EngineConfig& engine, WakeEvent* wake, int64_t now_us) {
  session_ = session;
  started_us_ = now_us;
  has_outcome_ = false;
  done_ = false;
  thread_ = std::thread([this, calib, &observations, &projection, &engine, wake] {
    NiceThisThread(kBackgroundNice);
    outcome_ = Calibrate(calib, observations, projection, engine);
    done_ = true;
    wake->Signal();
  });
}

void SolveRunner::Collect() {
  thread_.join();
  has_outcome_ = true;
}

void SolveRunner::Clear() {
  if (thread_.joinable()) thread_.join();
  has_outcome_ = false;
}

}  // namespace calibd
