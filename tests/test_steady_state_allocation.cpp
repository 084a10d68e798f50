// Issue 5: the per-frame path of our own code allocates nothing in steady state. A simulated drive
// goes through the agent's per-frame path as calibd-agent composes it (agent/src/agent.cpp: Init,
// OnCamera/OnLidar, Step with its SessionRecorder): raw LCM events published on an in-process
// memq:// bus, decoded by LcmBus into its reused messages, copied by FrameIntake into its slots,
// detected on its camera and LiDAR threads, drained into the pre-reserved SessionObservations and
// reported to the SessionMachine. Every `operator new` of the process (all threads) is counted
// while frame pairs 50-149 go through; frames 0-49 warm up (each intake slot, the tracker and the
// detectors' scratch reach their steady size). Expected: 0.
//
// Not counted, on purpose:
//  - The test's own work (simulating and encoding the frames, publishing them as the sensor
//    drivers would from their own processes) on the main thread and on the simulator's render
//    threads: see struct Harness.
//  - malloc() from C libraries, which operator new does not see: libapriltag's per-call results,
//    quad lists and decimated image (libapriltag 3.3 has no workspace API; see
//    core/src/camera_detector.cpp), liblcm's memq queue entries, and OpenCV's cv::Mat buffers
//    (cv::fastMalloc). They are outside the requirement ("our own code"). A cv::Mat header that
//    owns data is counted, though (OpenCV allocates its UMatData with operator new).
//
// Known and not covered: JPEG frames (camera_frame_t ENCODING_JPEG). cv::imdecode makes 3
// operator new calls per frame inside OpenCV 4.6's imgcodecs (the decoder object that findDecoder
// creates for every call, its state, and a std::string in the signature check), which no way of
// calling it avoids; an allocation-free JPEG path would decode with libjpeg directly into the
// slot's pre-allocated image (drivers/src/lcm_frames.cpp). These cases send mono8, as calibd-sim
// does by default. Checkerboard boards are not covered either: findChessboardCornersSB and
// EstimatePlanarPose (OpenCV) allocate on every frame; the boards here are AprilTags.
//
// Finding an allocation: CALIBD_ALLOC_BACKTRACES=N prints the stack of the first N counted
// allocations on stderr (addresses; resolve them with addr2line -Cfpe <test> in a -g build).

#include <execinfo.h>
#include <pthread.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <thread>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/agent/session_recorder.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/calibration_engine.hpp"
#include "calibd/drivers/lcm_bus.hpp"
#include "lcm_output.hpp"
#include "session.hpp"
#include "small_camera.hpp"

// ---- Counting operator new, every thread ----
namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
std::atomic<long> g_backtraces_left{0};
thread_local bool t_harness = false;  // the test's own work on this thread: not counted
thread_local bool t_in_trace = false;

// The simulator renders on threads of its own, started while the main thread works for the
// harness: they are told apart by their name, which Linux copies from the thread that starts them
// (the main thread takes this name while it works for the harness; see struct Harness).
constexpr char kHarnessThreadName[] = "alloc-harness";
bool OnHarnessThread() {
  if (t_harness) return true;
  thread_local int harness_thread = -1;  // the name of a thread other than main does not change
  if (harness_thread < 0) {
    char name[17] = {};
    prctl(PR_GET_NAME, name);
    harness_thread = std::strcmp(name, kHarnessThreadName) == 0 ? 1 : 0;
  }
  return harness_thread == 1;
}

void Count() {
  if (!g_counting.load(std::memory_order_relaxed) || OnHarnessThread()) return;
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (t_in_trace || g_backtraces_left.fetch_sub(1) <= 0) return;
  t_in_trace = true;  // backtrace() may allocate the first time (it loads libgcc_s)
  void* frames[32];
  const int n = backtrace(frames, 32);
  static const char kHeader[] = "---- counted operator new:\n";
  if (::write(2, kHeader, sizeof(kHeader) - 1) < 0) {
  }
  backtrace_symbols_fd(frames, n, 2);
  t_in_trace = false;
}

void* Allocate(std::size_t size) {
  Count();
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}

void* AllocateAligned(std::size_t size, std::align_val_t align) {
  Count();
  const auto a = static_cast<std::size_t>(align);
  // aligned_alloc wants a size that is a non-zero multiple of the alignment.
  const std::size_t rounded = size == 0 ? a : (size + a - 1) / a * a;
  if (void* p = std::aligned_alloc(a, rounded)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t size) { return Allocate(size); }
void* operator new[](std::size_t size) { return Allocate(size); }
void* operator new(std::size_t size, std::align_val_t align) {
  return AllocateAligned(size, align);
}
void* operator new[](std::size_t size, std::align_val_t align) {
  return AllocateAligned(size, align);
}
// These replacements pair with each other, but GCC 12 (-O2, as in the asan preset) inlines the
// delete into gtest's `new TestClass` sites and warns of a new/free mismatch that is not there.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace calibd {
namespace {

constexpr int kFrames = 160;      // frame pairs of the drive (16 s at 10 Hz)
constexpr int kCountFrom = 50;    // frames 0-49 warm up
constexpr int kCountUntil = 150;  // counted: pairs 50-149
constexpr int kFrameQueue = 2;    // as the agent's LCM queue per sensor channel

// RAII for the harness mark of the main thread (and of the threads it starts meanwhile).
class Harness {
 public:
  Harness() {
    pthread_getname_np(pthread_self(), name_, sizeof(name_));
    pthread_setname_np(pthread_self(), kHarnessThreadName);
    t_harness = true;
  }
  ~Harness() {
    t_harness = false;
    pthread_setname_np(pthread_self(), name_);
  }
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

 private:
  char name_[16] = {};
};

int64_t NowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// The agent's per-frame path (agent/src/agent.cpp), composed the same way.
class PerFramePath {
 public:
  bool Init(const AgentConfig& config, std::string* error) {
    if (!intake_.Init(IntakeConfigFrom(config), config.calib, error)) return false;
    recorder_.Init(config);
    if (!bus_.Open("memq://", error)) return false;
    if (!bus_.Subscribe<camera_frame_t>(
            channels::kCamera.name, kFrameQueue,
            [this](const camera_frame_t& m, int64_t) { intake_.OnCamera(m); }, error) ||
        !bus_.Subscribe<lidar_frame_t>(
            channels::kLidar.name, kFrameQueue,
            [this](const lidar_frame_t& m, int64_t) { intake_.OnLidar(m); }, error))
      return false;
    machine_ = SessionMachine(SessionConfigFrom(config));
    StartRequest request;
    request.requester = "test_steady_state_allocation";
    if (!machine_.Start(request, NowUs()).accepted) return false;
    recorder_.Clear();
    intake_.SetActive(true);
    return true;
  }

  LcmBus& bus() { return bus_; }
  FrameIntake& intake() { return intake_; }
  const SessionObservations& session() const { return recorder_.session(); }
  const SessionMachine& machine() const { return machine_; }
  const CollectionFigures& figures() const { return recorder_.figures(); }

  // The collecting part of Agent::Step.
  void Step() {
    const int64_t now = NowUs();
    if (recorder_.DrainFrom(&intake_) > 0) machine_.FrameRecorded(recorder_.figures(), now);
    machine_.Tick(now);
  }

  // Steps until every pair received has been drained.
  void StepUntilIdle() {
    while (!intake_.Idle()) {
      Step();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    Step();
  }

 private:
  FrameIntake intake_;
  SessionRecorder recorder_;
  SessionMachine machine_{SessionConfig{}};
  LcmBus bus_;
};

struct Case {
  const char* lidar_model;
  const char* encoding;  // "mono8" or "jpeg"
  /// The quarter-size test camera (960x480) instead of the default 3840x1920: a quicker
  /// simulation for the cases that are about the LiDAR path.
  bool small_camera;
};

class SteadyStateAllocationTest : public ::testing::TestWithParam<Case> {
 protected:
  void TearDown() override {
    g_counting = false;  // also after a failed assertion inside the counted frames
    t_harness = false;
  }
};

TEST_P(SteadyStateAllocationTest, PerFramePathAllocatesNothing) {
  const Case& param = GetParam();
  if (const char* n = std::getenv("CALIBD_ALLOC_BACKTRACES")) g_backtraces_left = std::atol(n);

  sim::SessionOptions options;
  options.seed = 7;
  options.lidar_model = param.lidar_model;
  options.image_encoding = param.encoding;
  options.trajectory.duration_s = kFrames / options.trajectory.rate_hz;
  if (param.small_camera) options.camera = testing::SmallCamera();
  sim::SessionSimulator simulator;
  std::string error;
  ASSERT_TRUE(simulator.Init(options, &error)) << error;
  ASSERT_GE(simulator.num_frames(), kFrames);

  // The agent's defaults, collecting through the whole drive (no early end on coverage).
  AgentConfig config;
  config.calib = simulator.UserConfig();
  config.lcm_url = "memq://";
  config.stop_on_coverage = false;
  config.max_frames = config.target_frames = 200;
  config.max_duration_s = 3600.0;
  ASSERT_TRUE(config.IsValid(&error)) << error;
  auto path = std::make_unique<PerFramePath>();
  ASSERT_TRUE(path->Init(config, &error)) << error;
  ASSERT_EQ(path->machine().state(), SessionState::kCollecting);

  const int8_t encoding = std::string(param.encoding) == "jpeg" ? camera_frame_t::ENCODING_JPEG
                                                                : camera_frame_t::ENCODING_MONO8;
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  camera_frame_t camera_msg;
  lidar_frame_t lidar_msg;
  std::vector<uint8_t> camera_bytes, lidar_bytes;
  long counted = 0, last = 0;
  // Counted from the end of frame k - 1's iteration to the end of frame k's (the workers run
  // behind the poll loop: a worker's allocation may show up one or two frames later).
  std::array<long, kFrames> per_frame{};
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < kFrames; ++k) {
    {
      // The sensors' side: simulate, convert and encode the frame pair.
      Harness harness;
      simulator.SimulateFrame(k, &image, &scan, &truth);
      ASSERT_TRUE(sim::ToCameraMessage(image, truth.camera_utime, config.calib.camera_id, encoding,
                                       options.jpeg_quality, &camera_msg));
      sim::ToLidarMessage(scan, truth.lidar_utime, config.calib.lidar_id, &lidar_msg);
      camera_bytes.resize(static_cast<size_t>(camera_msg.getEncodedSize()));
      lidar_bytes.resize(static_cast<size_t>(lidar_msg.getEncodedSize()));
      ASSERT_EQ(camera_msg.encode(camera_bytes.data(), 0, static_cast<int>(camera_bytes.size())),
                static_cast<int>(camera_bytes.size()));
      ASSERT_EQ(lidar_msg.encode(lidar_bytes.data(), 0, static_cast<int>(lidar_bytes.size())),
                static_cast<int>(lidar_bytes.size()));
    }
    // As a replay does (Agent::Run): hold back while every slot is busy, so that no pair drops.
    while (path->intake().Full()) {
      path->Step();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    if (k == kCountFrom) {
      path->StepUntilIdle();  // frames 0-49 done: steady state from here
      g_allocations = last = 0;
      g_counting = true;
    }
    {
      Harness harness;  // the sensor drivers publish from their own processes
      ASSERT_TRUE(path->bus().PublishRaw(channels::kCamera.name, camera_bytes.data(),
                                         camera_bytes.size(), &error))
          << error;
      ASSERT_TRUE(path->bus().PublishRaw(channels::kLidar.name, lidar_bytes.data(),
                                         lidar_bytes.size(), &error))
          << error;
    }
    // The poll loop: LCM decode -> FrameIntake::OnCamera / OnLidar, then Step.
    int handled = 0;
    while (handled < 2) {
      const int n = path->bus().Handle(0, 2 - handled);
      if (n <= 0) break;
      handled += n;
    }
    path->Step();
    if (k == kCountUntil - 1) {
      path->StepUntilIdle();  // pairs 50-149 detected and drained
      g_counting = false;
      counted = g_allocations.load();
    }
    per_frame[static_cast<size_t>(k)] = g_allocations.load() - last;
    last = g_allocations.load();
    Harness harness;
    ASSERT_EQ(handled, 2) << "frame " << k;
  }
  path->StepUntilIdle();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // The whole drive went through: no pair dropped or refused, boards recorded.
  const IntakeCounters& c = path->intake().counters();
  EXPECT_EQ(c.pairs_detected, kFrames) << c.last_error;
  EXPECT_EQ(c.dropped_queue_full, 0);
  EXPECT_EQ(c.bad_messages, 0) << c.last_error;
  EXPECT_EQ(c.over_capacity, 0);
  EXPECT_EQ(c.unpaired_camera + c.unpaired_lidar + c.out_of_order, 0);
  EXPECT_EQ(path->bus().decode_errors(), 0);
  EXPECT_EQ(path->machine().state(), SessionState::kCollecting);
  EXPECT_GT(path->figures().frames_with_boards, kFrames / 2);
  EXPECT_GT(path->session().lidar.size(), static_cast<size_t>(kFrames));

  std::string frames_with_allocations;
  for (int k = kCountFrom; k < kCountUntil; ++k)
    if (per_frame[static_cast<size_t>(k)] > 0)
      frames_with_allocations +=
          " " + std::to_string(k) + ":" + std::to_string(per_frame[static_cast<size_t>(k)]);
  std::printf("[ %s %s ] %d frame pairs in %.1f s; %ld operator new in pairs %d-%d\n",
              param.lidar_model, param.encoding, kFrames, seconds, counted, kCountFrom,
              kCountUntil - 1);
  EXPECT_EQ(counted, 0) << "operator new calls on the per-frame path in pairs " << kCountFrom << "-"
                        << kCountUntil - 1
                        << " (frame: count while it was handled; the workers run behind):"
                        << frames_with_allocations
                        << ". Set CALIBD_ALLOC_BACKTRACES=5 to see where.";
}

INSTANTIATE_TEST_SUITE_P(Lidars, SteadyStateAllocationTest,
                         ::testing::Values(Case{"ot128", "mono8", false}, Case{"m1", "mono8", true},
                                           Case{"falcon", "mono8", true}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.lidar_model) + "_" + p.param.encoding;
                         });

}  // namespace
}  // namespace calibd
