// Issues 5 and 8: the per-frame path of our own code allocates nothing in steady state, and what
// the C libraries under it allocate is bounded and does not grow. A simulated drive goes through
// the agent's per-frame path as calibd-agent composes it (agent/src/agent.cpp: Init,
// OnCamera/OnLidar, Step with its SessionRecorder): raw LCM events published on an in-process
// memq:// bus, decoded by LcmBus into its reused messages, copied by FrameIntake into its slots,
// detected on its camera and LiDAR threads, drained into the pre-reserved SessionObservations
// (thinned once it is full) and reported to the SessionMachine.
//
// kSimFrames frame pairs spread over a 16 s drive are simulated once and published again and
// again with advancing capture times: kWarmup pairs warm up (each intake slot, the tracker and the
// detectors' scratch reach their steady size), then kCounted pairs are counted. Two counts, of
// every thread except the test's own work (the harness, below):
//
// 1. `operator new` (replaced here): expected 0. It sees C++ allocations of our code and of the
//    C++ libraries (OpenCV allocates its UMatData with operator new: a cv::Mat header that owns
//    data is counted).
// 2. malloc/calloc/realloc/memalign/free (glibc's, interposed here and forwarded to
//    __libc_malloc & co.; operator new's own mallocs are left out): each call is attributed to
//    the loaded object its caller's code lies in. Measured (Release, small camera 960x480 mono8,
//    3 AprilTag boards, 2026-11-23), per frame pair, mean over 1000 pairs and the largest pair:
//      libapriltag.so.3  16939 calls, 13.5 MB  (largest pair: 38118 calls, 30.7 MB)
//      libc.so.6         3.3 calls, 4.8 kB     (qsort_r's merge buffer, for libapriltag's
//                                              zarray_sort)
//      liblcm, OpenCV, glib, calibd's code: none
//    AprilTag allocates on every apriltag_detector_detect and frees it all before returning
//    (libapriltag 3.3 has no workspace API; see core/src/camera/camera_detector.cpp): the decimated
//    and thresholded images, the union-find table, the cluster hash tables and quad lists (zarray,
//    grown by realloc), the results. LCM's memq:// allocates its queue entry on the publishing
//    side (the harness: not counted); Handle only frees it. The counts do not depend on the LiDAR
//    model (the LiDAR path calls no C library that allocates). Required: at most
//    kMaxMallocsPerPair calls and kMaxMallocBytesPerPair bytes in any pair (about twice the
//    largest measured; the first kBlock counted pairs go through one at a time to be counted
//    alone), none called from our own code (this executable: calibd's libraries are linked into
//    it), and no growth: the bytes live (malloc'd minus freed, by malloc_usable_size) at the end
//    of the window within kMaxLiveGrowthBytes of those at its start, and no more calls or bytes
//    in the last kBlock pairs than in the first kBlock (the same simulated pairs in the same
//    order). Not measured here: udpm:// (the vehicle's transport) reassembles each fragmented
//    message (images, sweeps) in a buffer liblcm mallocs on its receive thread.
//    Under AddressSanitizer (it replaces malloc) only part 1 runs.
//
// Every case uses the small camera: 1000 pairs at 3840x1920 would take minutes. The first case
// (m1, the quickest LiDAR to simulate and detect) counts 1000 pairs; the others, which differ
// only in the LiDAR or (m1_jpeg) in the camera frames' encoding, count 200.
//
// Not counted, on purpose: the test's own work (simulating and encoding the frames, publishing
// them as the sensor drivers would from their own processes) on the main thread and on the
// simulator's render threads: see struct Harness.
//
// JPEG frames (camera_frame_t ENCODING_JPEG; case m1_jpeg, 200 pairs): decoded by libjpeg-turbo
// directly into the intake's pre-allocated image (drivers/src/jpeg_decoder.cpp), no operator new.
// libjpeg mallocs its image pool for each frame in jpeg_start_decompress and frees it when the
// image is finished: measured 3.0 calls, 25 kB per pair (libjpeg.so.62; 960x480 grey, quality
// 95). Before, cv::imdecode made 3 operator new calls per frame inside OpenCV 4.6's imgcodecs,
// which calibd-agent no longer links. The other cases send mono8, as calibd-sim does by default.
// Not covered: bgr8 frames, and checkerboard boards: findChessboardCornersSB and
// EstimatePlanarPose (OpenCV) allocate on every frame; the boards here are AprilTags.
//
// Finding an allocation: CALIBD_ALLOC_BACKTRACES=N prints the stack of the first N counted
// operator new calls on stderr, CALIBD_MALLOC_BACKTRACES=N those of the first N counted mallocs
// (CALIBD_MALLOC_BACKTRACES_FROM=NAME: only those called from a loaded object whose file name
// contains NAME, e.g. libc.so). Addresses: resolve them with addr2line -Cfpe <object> <offset>.

#include <execinfo.h>
#include <link.h>
#include <malloc.h>
#include <pthread.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <thread>
#include <vector>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/agent/session_recorder.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/drivers/lcm_bus.hpp"
#include "lcm_output.hpp"
#include "session.hpp"
#include "small_camera.hpp"

// AddressSanitizer brings its own malloc: interposing glibc's here would bypass it.
#if defined(__SANITIZE_ADDRESS__)
#define CALIBD_COUNT_MALLOC 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CALIBD_COUNT_MALLOC 0
#endif
#endif
#ifndef CALIBD_COUNT_MALLOC
#define CALIBD_COUNT_MALLOC 1
#endif

// ---- Counting operator new and malloc, every thread ----
namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};  // operator new
std::atomic<long> g_backtraces_left{0};
thread_local bool t_harness = false;  // the test's own work on this thread: not counted
thread_local bool t_in_trace = false;
thread_local bool t_in_new = false;  // inside operator new/delete: their malloc/free not counted

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

void PrintBacktrace(const char* header) {
  t_in_trace = true;  // backtrace() may allocate the first time (it loads libgcc_s)
  void* frames[32];
  const int n = backtrace(frames, 32);
  if (::write(2, header, std::strlen(header)) < 0) {
  }
  backtrace_symbols_fd(frames, n, 2);
  t_in_trace = false;
}

void Count() {
  if (!g_counting.load(std::memory_order_relaxed) || OnHarnessThread()) return;
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (t_in_trace || g_backtraces_left.fetch_sub(1) <= 0) return;
  PrintBacktrace("---- counted operator new:\n");
}

// RAII: operator new/delete's own malloc/free, counted as operator new (or not at all).
struct InNew {
  InNew() { t_in_new = true; }
  ~InNew() { t_in_new = false; }
};

void* Allocate(std::size_t size) {
  Count();
  InNew in_new;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}

void* AllocateAligned(std::size_t size, std::align_val_t align) {
  Count();
  InNew in_new;
  const auto a = static_cast<std::size_t>(align);
  // aligned_alloc wants a size that is a non-zero multiple of the alignment.
  const std::size_t rounded = size == 0 ? a : (size + a - 1) / a * a;
  if (void* p = std::aligned_alloc(a, rounded)) return p;
  throw std::bad_alloc();
}

void Free(void* p) {
  InNew in_new;
  std::free(p);
}

// ---- malloc: the callers' objects, the counts (used by the interposers below) ----
// The loaded objects (executable and shared libraries), each with the span of its segments and
// the malloc calls whose caller's code lies in it. Listed before counting (ListLoadedObjects);
// the last entry takes callers outside every listed object.
constexpr int kMaxObjects = 256;
struct LoadedObject {
  uintptr_t begin = 0, end = 0;
  char name[96] = {};
  std::atomic<long> calls{0}, bytes{0};
};
LoadedObject g_objects[kMaxObjects + 1];
int g_num_objects = 0;
int g_executable = -1;  // this test: calibd's libraries are linked into it

std::atomic<long> g_live_bytes{0};  // malloc'd minus freed, whole process, always counted
std::atomic<long> g_mallocs{0}, g_malloc_bytes{0}, g_frees{0};  // while counting, not harness
std::atomic<long> g_malloc_backtraces_left{0};
const char* g_malloc_backtraces_from = nullptr;

int AddObject(dl_phdr_info* info, size_t, void*) {
  if (g_num_objects >= kMaxObjects) return 1;
  LoadedObject& o = g_objects[g_num_objects];
  o.begin = UINTPTR_MAX;
  o.end = 0;
  for (int i = 0; i < info->dlpi_phnum; ++i) {
    const ElfW(Phdr)& ph = info->dlpi_phdr[i];
    if (ph.p_type != PT_LOAD) continue;
    o.begin = std::min<uintptr_t>(o.begin, info->dlpi_addr + ph.p_vaddr);
    o.end = std::max<uintptr_t>(o.end, info->dlpi_addr + ph.p_vaddr + ph.p_memsz);
  }
  if (o.end == 0) return 0;
  const char* path = info->dlpi_name;
  if (path == nullptr || path[0] == '\0') {
    path = "test executable (calibd's code)";
    if (g_executable < 0) g_executable = g_num_objects;
  } else if (const char* slash = std::strrchr(path, '/')) {
    path = slash + 1;
  }
  std::snprintf(o.name, sizeof(o.name), "%s", path);
  ++g_num_objects;
  return 0;
}

void ListLoadedObjects() {
  if (g_num_objects > 0) return;
  dl_iterate_phdr(AddObject, nullptr);
  std::snprintf(g_objects[kMaxObjects].name, sizeof(g_objects[kMaxObjects].name),
                "(no object listed)");
}

#if CALIBD_COUNT_MALLOC
int ObjectOf(const void* address) {
  const auto a = reinterpret_cast<uintptr_t>(address);
  for (int i = 0; i < g_num_objects; ++i)
    if (a >= g_objects[i].begin && a < g_objects[i].end) return i;
  return kMaxObjects;
}

// `size`: the bytes asked for (the usable size depends on the heap's layout); `old_usable`: those
// of the block a realloc replaced.
void CountMalloc(void* p, size_t size, long old_usable, const void* caller) {
  if (p == nullptr) return;
  g_live_bytes.fetch_add(static_cast<long>(malloc_usable_size(p)) - old_usable,
                         std::memory_order_relaxed);
  if (t_in_new || !g_counting.load(std::memory_order_relaxed) || OnHarnessThread()) return;
  const auto bytes = static_cast<long>(size);
  g_mallocs.fetch_add(1, std::memory_order_relaxed);
  g_malloc_bytes.fetch_add(bytes, std::memory_order_relaxed);
  LoadedObject& o = g_objects[ObjectOf(caller)];
  o.calls.fetch_add(1, std::memory_order_relaxed);
  o.bytes.fetch_add(bytes, std::memory_order_relaxed);
  if (t_in_trace || g_malloc_backtraces_left.load(std::memory_order_relaxed) <= 0) return;
  if (g_malloc_backtraces_from && !std::strstr(o.name, g_malloc_backtraces_from)) return;
  if (g_malloc_backtraces_left.fetch_sub(1) <= 0) return;
  PrintBacktrace("---- counted malloc:\n");
}

void CountFree(void* p) {
  if (p == nullptr) return;
  g_live_bytes.fetch_sub(static_cast<long>(malloc_usable_size(p)), std::memory_order_relaxed);
  if (t_in_new || !g_counting.load(std::memory_order_relaxed) || OnHarnessThread()) return;
  g_frees.fetch_add(1, std::memory_order_relaxed);
}
#endif  // CALIBD_COUNT_MALLOC
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
void operator delete(void* p) noexcept { Free(p); }
void operator delete(void* p, std::size_t) noexcept { Free(p); }
void operator delete[](void* p) noexcept { Free(p); }
void operator delete[](void* p, std::size_t) noexcept { Free(p); }
void operator delete(void* p, std::align_val_t) noexcept { Free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { Free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { Free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { Free(p); }
#pragma GCC diagnostic pop

#if CALIBD_COUNT_MALLOC
// glibc's allocator under its exported internal names (glibc 2.36), so that no dlsym is needed
// (dlsym itself allocates). Defined in the executable, these replace malloc & co. for every
// library of the process (glibc supports it: "Replacing malloc", glibc manual 3.2.5).
extern "C" {
void* __libc_malloc(size_t size);
void __libc_free(void* p);
void* __libc_calloc(size_t n, size_t size);
void* __libc_realloc(void* p, size_t size);
void* __libc_memalign(size_t alignment, size_t size);
void* __libc_valloc(size_t size);
void* __libc_pvalloc(size_t size);

void* malloc(size_t size) noexcept {
  void* p = __libc_malloc(size);
  CountMalloc(p, size, 0, __builtin_return_address(0));
  return p;
}
void free(void* p) noexcept {
  CountFree(p);
  __libc_free(p);
}
void* calloc(size_t n, size_t size) noexcept {
  void* p = __libc_calloc(n, size);
  CountMalloc(p, n * size, 0, __builtin_return_address(0));
  return p;
}
void* realloc(void* old, size_t size) noexcept {
  const long old_usable = old ? static_cast<long>(malloc_usable_size(old)) : 0;
  void* p = __libc_realloc(old, size);
  if (p != nullptr) {
    CountMalloc(p, size, old_usable, __builtin_return_address(0));
  } else if (old != nullptr && size == 0) {
    g_live_bytes.fetch_sub(old_usable, std::memory_order_relaxed);  // realloc(p, 0) frees p
  }
  return p;
}
void* memalign(size_t alignment, size_t size) noexcept {
  void* p = __libc_memalign(alignment, size);
  CountMalloc(p, size, 0, __builtin_return_address(0));
  return p;
}
void* aligned_alloc(size_t alignment, size_t size) noexcept {
  void* p = __libc_memalign(alignment, size);
  CountMalloc(p, size, 0, __builtin_return_address(0));
  return p;
}
int posix_memalign(void** out, size_t alignment, size_t size) noexcept {
  if (alignment % sizeof(void*) != 0 || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  CountMalloc(p, size, 0, __builtin_return_address(0));
  *out = p;
  return 0;
}
void* valloc(size_t size) noexcept {
  void* p = __libc_valloc(size);
  CountMalloc(p, size, 0, __builtin_return_address(0));
  return p;
}
void* pvalloc(size_t size) noexcept {
  void* p = __libc_pvalloc(size);
  CountMalloc(p, size, 0, __builtin_return_address(0));
  return p;
}
}  // extern "C"
#endif  // CALIBD_COUNT_MALLOC

namespace calibd {
namespace {

// The drive: kSimFrames pairs simulated once, every kSimStride-th of a 16 s drive at 10 Hz (all
// distances, 6 to 30 m and back), then published in a loop with advancing capture times.
constexpr int kSimFrames = 20;
constexpr int kSimStride = 8;
constexpr int kWarmup = 50;  // pairs 0-49 warm up, then Case::counted pairs are counted
constexpr int kBlock = 100;  // the first and the last kBlock counted pairs are compared
static_assert(kBlock % kSimFrames == 0, "the blocks repeat the same simulated pairs");
constexpr int64_t kPeriodUs = 100000;  // 10 Hz
constexpr int kFrameQueue = 2;         // as the agent's LCM queue per sensor channel

// Bounds of the C libraries' mallocs (see the top of the file): about twice the largest count
// measured in one pair, and the live bytes allowed to differ between the window's ends.
constexpr long kMaxMallocsPerPair = 80000;          // measured: 38118
constexpr long kMaxMallocBytesPerPair = 64L << 20;  // measured: 30.7 MB
constexpr long kMaxLiveGrowthBytes = 64L << 10;     // measured: 0

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
    if (!intake_.AwaitStartup()) {
      *error = intake_.startup().error;
      return false;
    }
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
  const SessionThinning& thinning() const { return recorder_.thinning(); }

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
  int counted;        ///< pairs counted after the warm-up: a multiple of kSimFrames, >= 2 x kBlock
  bool jpeg = false;  ///< camera frames sent as JPEG (decoded by libjpeg-turbo), else mono8
};

// Sets the big-endian int64 at `offset` of an encoded LCM message (after the 8-byte type hash,
// `utime` is the first field of camera_frame_t and lidar_frame_t).
void SetUtime(std::vector<uint8_t>* bytes, int64_t utime) {
  auto u = static_cast<uint64_t>(utime);
  for (int i = 7; i >= 0; --i, u >>= 8)
    (*bytes)[8 + static_cast<size_t>(i)] = static_cast<uint8_t>(u);
}

// One simulated pair, encoded as its sensors' drivers publish it.
struct EncodedPair {
  std::vector<uint8_t> camera, lidar;
  int64_t camera_utime = 0, lidar_utime = 0;
};

struct MallocSnapshot {
  long calls = 0, bytes = 0, frees = 0;
  static MallocSnapshot Now() { return {g_mallocs.load(), g_malloc_bytes.load(), g_frees.load()}; }
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
  ASSERT_EQ(param.counted % kSimFrames, 0);
  ASSERT_GE(param.counted, 2 * kBlock);
  const int kCounted = param.counted;
  const int kFrames = kWarmup + kCounted;
  if (const char* n = std::getenv("CALIBD_ALLOC_BACKTRACES")) g_backtraces_left = std::atol(n);
  if (const char* n = std::getenv("CALIBD_MALLOC_BACKTRACES"))
    g_malloc_backtraces_left = std::atol(n);
  g_malloc_backtraces_from = std::getenv("CALIBD_MALLOC_BACKTRACES_FROM");
  {
    void* frame[1];
    backtrace(frame, 1);  // loads libgcc_s now, not while counting
  }

  sim::SessionOptions options;
  options.seed = 7;
  options.lidar_model = param.lidar_model;
  options.trajectory.duration_s = kSimFrames * kSimStride / options.trajectory.rate_hz;
  options.camera = testing::SmallCamera();
  sim::SessionSimulator simulator;
  std::string error;
  ASSERT_TRUE(simulator.Init(options, &error)) << error;
  ASSERT_GE(simulator.num_frames(), kSimFrames * kSimStride);

  // The sensors' side, once: simulate, convert and encode the pairs (mono8, as calibd-sim sends,
  // or JPEG).
  std::vector<EncodedPair> pairs(kSimFrames);
  {
    Harness harness;
    cv::Mat image;
    sim::LidarScan scan;
    sim::FrameTruth truth;
    camera_frame_t camera_msg;
    lidar_frame_t lidar_msg;
    for (int i = 0; i < kSimFrames; ++i) {
      EncodedPair& pair = pairs[static_cast<size_t>(i)];
      simulator.SimulateFrame(i * kSimStride, &image, &scan, &truth);
      ASSERT_TRUE(sim::ToCameraMessage(
          image, truth.camera_utime, simulator.UserConfig().camera_id,
          param.jpeg ? camera_frame_t::ENCODING_JPEG : camera_frame_t::ENCODING_MONO8,
          options.jpeg_quality, &camera_msg));
      sim::ToLidarMessage(scan, truth.lidar_utime, simulator.UserConfig().lidar_id, &lidar_msg);
      pair.camera.resize(static_cast<size_t>(camera_msg.getEncodedSize()));
      pair.lidar.resize(static_cast<size_t>(lidar_msg.getEncodedSize()));
      ASSERT_EQ(camera_msg.encode(pair.camera.data(), 0, static_cast<int>(pair.camera.size())),
                static_cast<int>(pair.camera.size()));
      ASSERT_EQ(lidar_msg.encode(pair.lidar.data(), 0, static_cast<int>(pair.lidar.size())),
                static_cast<int>(pair.lidar.size()));
      pair.camera_utime = truth.camera_utime;
      pair.lidar_utime = truth.lidar_utime;
    }
    // SetUtime writes where the decoder reads utime.
    SetUtime(&pairs[0].camera, 12345);
    ASSERT_EQ(
        camera_msg.decode(pairs[0].camera.data(), 0, static_cast<int>(pairs[0].camera.size())),
        static_cast<int>(pairs[0].camera.size()));
    EXPECT_EQ(camera_msg.utime, 12345);
  }

  // The agent's defaults, collecting through the whole drive (no early end on coverage or on
  // target_frames): max_frames 200, so the store is thinned several times.
  AgentConfig config;
  config.calib = simulator.UserConfig();
  config.lcm_url = "memq://";
  config.stop_on_coverage = false;
  config.target_frames = 100000;
  config.max_duration_s = 3600.0;
  ASSERT_TRUE(config.IsValid(&error)) << error;
  auto path = std::make_unique<PerFramePath>();
  ASSERT_TRUE(path->Init(config, &error)) << error;
  ASSERT_EQ(path->machine().state(), SessionState::kCollecting);
  ListLoadedObjects();

  // Per pair, counted from the end of pair k - 1's iteration to the end of pair k's.
  std::vector<long> news(kFrames), mallocs(kFrames), malloc_bytes(kFrames), frees(kFrames);
  long news_last = 0, live_start = 0, live_end = 0;
  MallocSnapshot last;
  const int64_t first_lidar_utime = pairs[0].lidar_utime;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < kFrames; ++k) {
    // As a replay does (Agent::Run): hold back while every slot is busy, so that no pair drops.
    while (path->intake().Full()) {
      path->Step();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    if (k == kWarmup) {
      path->StepUntilIdle();  // warm-up done: steady state from here
      g_allocations = news_last = 0;
      last = MallocSnapshot::Now();
      live_start = g_live_bytes.load();
      for (LoadedObject& o : g_objects) o.calls = o.bytes = 0;
      g_counting = true;
    }
    {
      // The sensor drivers publish from their own processes: the capture times advance by one
      // period per pair, the simulated pairs repeat.
      Harness harness;
      EncodedPair& pair = pairs[static_cast<size_t>(k % kSimFrames)];
      const int64_t shift = first_lidar_utime + k * kPeriodUs - pair.lidar_utime;
      SetUtime(&pair.camera, pair.camera_utime + shift);
      SetUtime(&pair.lidar, pair.lidar_utime + shift);
      ASSERT_TRUE(path->bus().PublishRaw(channels::kCamera.name, pair.camera.data(),
                                         pair.camera.size(), &error))
          << error;
      ASSERT_TRUE(path->bus().PublishRaw(channels::kLidar.name, pair.lidar.data(),
                                         pair.lidar.size(), &error))
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
    // The first kBlock counted pairs one at a time, so that each pair's count is its own (the
    // workers run behind the poll loop: a pair's detections may end several iterations after it
    // was published); the others as the agent runs. The last block starts with nothing in flight.
    if ((k >= kWarmup && k < kWarmup + kBlock) || k == kFrames - kBlock - 1) path->StepUntilIdle();
    if (k == kFrames - 1) {
      path->StepUntilIdle();  // every pair detected and drained
      g_counting = false;
      live_end = g_live_bytes.load();
    }
    const MallocSnapshot now = MallocSnapshot::Now();
    const auto i = static_cast<size_t>(k);
    news[i] = g_allocations.load() - news_last;
    news_last = g_allocations.load();
    mallocs[i] = now.calls - last.calls;
    malloc_bytes[i] = now.bytes - last.bytes;
    frees[i] = now.frees - last.frees;
    last = now;
    Harness harness;
    ASSERT_EQ(handled, 2) << "frame " << k;
  }
  const double seconds = SecondsSince(t0);

  // The whole drive went through: no pair dropped or refused, boards recorded, the store thinned.
  const IntakeCounters& c = path->intake().counters();
  EXPECT_EQ(c.pairs_detected, kFrames) << c.last_error;
  EXPECT_EQ(c.dropped_queue_full, 0);
  EXPECT_EQ(c.bad_messages, 0) << c.last_error;
  EXPECT_EQ(c.over_capacity, 0);
  EXPECT_EQ(c.unpaired_camera + c.unpaired_lidar + c.out_of_order, 0);
  EXPECT_EQ(c.camera_missed + c.lidar_missed, 0);
  EXPECT_EQ(path->bus().decode_errors(), 0);
  EXPECT_EQ(path->machine().state(), SessionState::kCollecting);
  EXPECT_GT(path->figures().frames_with_boards, kFrames / 2);
  EXPECT_GE(path->thinning().stride(), 2);

  // 1. operator new: none.
  const long counted = g_allocations.load();
  std::string frames_with_allocations;
  for (int k = kWarmup; k < kFrames; ++k)
    if (news[static_cast<size_t>(k)] > 0 && frames_with_allocations.size() < 400)
      frames_with_allocations +=
          " " + std::to_string(k) + ":" + std::to_string(news[static_cast<size_t>(k)]);
  std::printf("[ %s ] %d frame pairs in %.1f s; %ld operator new in pairs %d-%d\n",
              param.lidar_model, kFrames, seconds, counted, kWarmup, kFrames - 1);
  EXPECT_EQ(counted, 0) << "operator new calls on the per-frame path in pairs " << kWarmup << "-"
                        << kFrames - 1
                        << " (frame: count while it was handled; the workers run behind):"
                        << frames_with_allocations
                        << ". Set CALIBD_ALLOC_BACKTRACES=5 to see where.";

  // 2. malloc: bounded per pair, none from our code, no growth.
#if CALIBD_COUNT_MALLOC
  auto block = [&](int from, int n, const std::vector<long>& v) {
    long sum = 0;
    for (int k = from; k < from + n; ++k) sum += v[static_cast<size_t>(k)];
    return sum;
  };
  const long total_calls = block(kWarmup, kCounted, mallocs);
  const long total_bytes = block(kWarmup, kCounted, malloc_bytes);
  const long total_frees = block(kWarmup, kCounted, frees);
  // The largest pair, of those counted one at a time.
  long max_calls = 0, max_bytes = 0;
  int max_calls_at = 0;
  for (int k = kWarmup; k < kWarmup + kBlock; ++k) {
    const auto i = static_cast<size_t>(k);
    if (mallocs[i] > max_calls) max_calls_at = k;
    max_calls = std::max(max_calls, mallocs[i]);
    max_bytes = std::max(max_bytes, malloc_bytes[i]);
  }
  const long first_calls = block(kWarmup, kBlock, mallocs);
  const long last_calls = block(kFrames - kBlock, kBlock, mallocs);
  const long first_bytes = block(kWarmup, kBlock, malloc_bytes);
  const long last_bytes = block(kFrames - kBlock, kBlock, malloc_bytes);
  std::printf(
      "[ %s ] malloc in pairs %d-%d: %.1f calls and %.0f bytes per pair (most in one of the "
      "first %d pairs: %ld calls at pair %d, %ld bytes), %.1f frees per pair; first/last %d "
      "pairs: %ld/%ld calls, %ld/%ld bytes; bytes live at the end minus the start: %ld\n",
      param.lidar_model, kWarmup, kFrames - 1, static_cast<double>(total_calls) / kCounted,
      static_cast<double>(total_bytes) / kCounted, kBlock, max_calls, max_calls_at, max_bytes,
      static_cast<double>(total_frees) / kCounted, kBlock, first_calls, last_calls, first_bytes,
      last_bytes, live_end - live_start);
  for (int o = 0; o <= kMaxObjects; ++o) {
    const LoadedObject& object = g_objects[o];
    if (object.calls.load() == 0) continue;
    std::printf("    called from %-40s %8.2f calls %10.0f bytes per pair\n", object.name,
                static_cast<double>(object.calls.load()) / kCounted,
                static_cast<double>(object.bytes.load()) / kCounted);
  }
  ASSERT_GE(g_executable, 0);
  EXPECT_EQ(g_objects[g_executable].calls.load(), 0)
      << "malloc called from our own code; set CALIBD_MALLOC_BACKTRACES=5 "
         "CALIBD_MALLOC_BACKTRACES_FROM=test_steady to see where";
  EXPECT_LE(max_calls, kMaxMallocsPerPair)
      << "at pair " << max_calls_at << "; set CALIBD_MALLOC_BACKTRACES=5 to see where";
  EXPECT_LE(max_bytes, kMaxMallocBytesPerPair);
  EXPECT_LE(last_calls, first_calls) << "the mallocs per pair grow with the number of pairs";
  EXPECT_LE(last_bytes, first_bytes) << "the malloc'd bytes per pair grow with the number of pairs";
  EXPECT_LE(std::labs(live_end - live_start), kMaxLiveGrowthBytes)
      << "bytes live at the end of the window minus those at its start";
#else
  static_cast<void>(live_end - live_start);
  std::printf(
      "[ %s ] malloc not counted: AddressSanitizer replaces malloc (only the operator "
      "new part ran)\n",
      param.lidar_model);
#endif
}

INSTANTIATE_TEST_SUITE_P(Lidars, SteadyStateAllocationTest,
                         // 1000 pairs with the quickest LiDAR (the camera side is the same
                         // for all), 200 for the others' LiDAR paths.
                         // JPEG camera frames: the m1 drive again, 200 pairs.
                         ::testing::Values(Case{"m1", 1000}, Case{"ot128", 200},
                                           Case{"falcon", 200}, Case{"m1", 200, true}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.lidar_model) + (p.param.jpeg ? "_jpeg" : "");
                         });

}  // namespace
}  // namespace calibd
