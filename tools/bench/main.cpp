// calibd-bench: evaluation and speed benchmarks that print tables (and JSON with --json).

#include <iostream>
#include <string>

#include "bench_command_line.hpp"
#include "command_line.hpp"
#include "seed_kind.hpp"

namespace {

constexpr const char* kHelp =
    R"(calibd-bench: evaluation and speed benchmarks on simulated sessions.

Usage: calibd-bench detect [options]
       calibd-bench calib [options]
       calibd-bench agent-memory [options]
       calibd-bench pipeline [options]
       calibd-bench resolution [--repeat N]
       calibd-bench soak --drive LOG --calib-yaml FILE [options]
       calibd-bench recordings [options]
       calibd-bench verdicts [options]
       calibd-bench time-offset [options]

detect   camera and LiDAR board detection over the default simulated session (3 boards, clutter,
         driving 6-30 m): precision, recall (a LiDAR detection is a true positive within 0.2 m of
         a true board centre, paper IV-B), a precision/recall curve over thresholds 0.70-0.99,
         camera corner error against the truth, and median/p95 time per frame of each stage.
  --lidar LIST        comma-separated models (default ot128,m1,falcon)
  --frames N          frame pairs per session (default 200)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --json FILE         also write the figures as JSON

calib    calibration over simulated drives, each detected once with the real detectors, then
         calibrated by the engine in every setting of the paper's experiments (IV):
         1. rotation/translation error of the default direct method and grid-search/optimisation
            times against our targets (0.05 deg, 0.015 m, 50 ms, 300 ms) and the paper's times;
         2. Table I: mean reprojection error (px) for alpha 0.1 ... 0 m, indirect and direct;
         3. Table II: STD over the drives of the roll/pitch/yaw error (LiDAR axes) with boards
            only close (< 8.5 m) or only far (> 25 m): indirect, direct (Eq. 4), direct with
            board-pose refinement;
         4. Fig. 7: the same STD when a pair is kept only once the vehicle is d = 0, 0.5, 1,
            2 or 4 m (straight line) from where the last kept pair was taken;
         5. grid-search convergence from priors rotated by up to +-10 deg, with and without it.
         A figure the engine could not produce shows its reason code. A full run (3 LiDARs x 5
         drives x 200 pairs, 100 trials) takes 30-60 min on 2 cores; progress on stderr.
  --lidar LIST        comma-separated models (default ot128,m1,falcon)
  --trajectories N    drives per LiDAR, seeds seed .. seed+N-1 (default 5)
  --frames N          frame pairs per drive (default 200; fewer make a faster drive, 6-30 m)
  --seed N            first simulation seed (default 1; its kind: Seeds, below)
  --trials N          grid-search trials with and without the search (default 100; 0 skips)
  --json FILE         also write the figures as JSON

agent-memory
         the agent's fixed memory on the real process: one simulated drive published live over
         LCM udpm at 10 Hz in a private network namespace (needs root), once per session and
         looped (capture times shifted) for the longer ones, to calibd-agent with one config;
         per session: frames received / missing / dropped per sensor, pairs used by the solve,
         the verdict and the agent's peak RSS (ru_maxrss) against the first session's (target:
         within 5%). Real time: 200 + 2000 pairs take about 4 min.
  --agent PATH        calibd-agent to run (default: this build's)
  --lidar MODEL       ot128 | m1 | falcon (default ot128)
  --frames N          frame pairs of the drive (default 200)
  --loops LIST        comma-separated: one session per entry, the drive published that many
                      times (default 1,10: sessions of 200 and 2000 pairs)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --work-dir DIR      keep the log, configs, stores and outputs there (default: a temporary
                      directory, removed)
  --json FILE         also write the figures as JSON

pipeline the time and CPU of every stage against the paper's (§IV-E: 18.7 s LiDAR and 4.93 s
         camera detection, 0.12 s grid search, 1.25 s direct and 1.63 s indirect optimisation,
         200 pairs, 12-thread i7-10750H) and our 2-core targets, per LiDAR model: the default
         drive (3840x1920) detected in process, frame by frame (wall median/p95 and process CPU),
         then the engine (the agent's default: grid, refined direct solve, gates, re-solves;
         and Eq. 4 and the indirect method alone); then the same drive published live over LCM
         (private network namespace, needs root) to calibd-agent: start to READY=1, last frame
         to result, the agent's CPU time and peak RSS. About 2.5 min per model on 2 cores.
  --lidar LIST        comma-separated models (default ot128,m1,falcon)
  --frames N          frame pairs per drive (default 200)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --engine-runs N     runs of each in-process engine configuration; the median run's figures
                      (default 5)
  --agent PATH|none   calibd-agent to run (default: this build's; none skips the live part)
  --work-dir DIR      keep the agent runs' configs, stores and outputs there
  --json FILE         also write the figures as JSON

resolution
         the generic LiDAR's resolution estimate (core/lidar_resolution.hpp) on one simulated
         workshop sweep of each model (ot128 ~216k points, m1, falcon), without rings: the
         estimated azimuth and elevation resolution, the median and p95 wall time of N runs
         and the median CPU time of the thread (target: < 20 ms for 200k points).
  --repeat N          timed runs per model (default 50)

soak     one calibd-agent through back-to-back workshop sessions for N minutes: calibd-sim
         publishes the drive over LCM (looping); a tester over CAN (UDS on the kernel's ISO-TP,
         calibd-tester's client) unlocks, calibrates, commits and restores the reference, session
         after session; the agent's RSS, open fds, threads and CPU time are read from /proc once a
         second. One row per session, then the checks: every session updated, committed and
         restored; the agent alive and stopping cleanly; no fd or thread more and at most
         --max-rss-growth-mb more RSS after any session than after the first; from 16 sessions
         on, at most 1 MB more RSS over the second half; the store within its history. Needs a CAN interface with can-isotp: tests/vm/soak.sh MINUTES runs it in
         the test VM on the agent_diag_vmtest drive.
  --minutes X         start sessions until X minutes have passed (default 2)
  --drive LOG         the drive to publish (calibd-sim --out; required)
  --calib-yaml FILE   its calibration config (calibd-sim --config-out; required)
  --agent PATH        calibd-agent to run (default: this build's)
  --sim PATH          calibd-sim to publish with (default: this build's)
  --interface NAME    CAN interface (default vcan0)
  --lcm-url URL       where the drive goes and the agent listens
                      (default udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216)
  --speed X           replay speed of the drive (default 1)
  --min-frames N      the agent's min_frames (default 60)
  --min-distance-bins N
                      the agent's min_distance_bins (default: the agent's; 1 for a drive within 8.5 m)
  --max-translation-bound-m M
                      the agent's engine.verdict.max_translation_bound_m (default: the agent's)
  --max-rotation-bound-deg D
                      the agent's engine.verdict.max_rotation_bound_deg (default: the agent's)
  --p2-ms MS          the tester's P2 (default 2000, for an emulated guest)
  --max-rss-growth-mb X
                      allowed RSS growth after the first session (default 16)
  --work-dir DIR      the agent's config, store, logs (default: a temporary directory, kept)
  --json FILE         also write the sessions and every sample as JSON

recordings
         still-pose sessions as other rigs record them (one board on a tripod or held by a
         person among furniture, 1.5-10 m; VLP-16, VLP-32C, OS1-64, Livox-Avia- and Mid-360-like
         LiDARs; pinhole and fisheye cameras), each calibrated from a config with only the board
         geometry, intrinsics, the LiDAR model's name and a prior 8 deg / 15 cm off: LiDAR board
         recall and precision (per frame, and of what the engine keeps after dropping static
         scenery), verdict, error against the truth and grid-search convergence from
         priors rotated by up to +-10 deg (a trial converged when it ends within 0.05 deg of
         the engine started from the truth), against the targets. Fails when a target is
         missed.
  --scenario LIST     comma-separated scenarios (default: all)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --trials N          grid-search trials per scenario (default 20; 0 skips)
  --extract-planes on|off
                      search clusters refused as a whole for board planes (LiDAR detector's
                      extract_planes; default on, as calibd-calibrate)
  --json FILE         also write the figures as JSON

verdicts the fault campaign: simulated sessions (every LiDAR model, drives at 4-14 m and still
         poses at 1.5-8 m, 1-3 boards, a 1920 x 1200 camera), each clean or with one fault drawn at
         a random size: the camera 0-100 ms late with wrong stamps or no capture times, board or
         tag size 1-5 % off, focal length 0.5-3 % off, principal point 5-20 px off, LiDAR ranges
         2-5 cm biased, the tag configured 10-40 mm off-centre, another lens's distortion, frame
         pairs 1 s apart while driving (camera late), the camera's clock drifting 200-3000 ppm,
         another LiDAR model configured, frame pairs shuffled or each twice, a prior beyond the
         grid search's reach, a ring LiDAR's lasers 0.05-0.2 deg off their table's elevations,
         someone in front of every board hiding 10-40 % of it (still poses), two boards of
         different sizes with their ids swapped in the config, boards bent 5-20 mm, still
         poses whose boards are still carried at 0.2-1 m/s with the camera 10-50 ms late, a
         rolling shutter reading out over 10-40 ms while driving, boards out at 25-40 m (23
         faults: 368 sessions meet every LiDAR in both modes with each). A round's faults that
         change only the config, the stamps, the order of the pairs, the LiDAR's noise or the
         camera derive from its clean session's recording (its scene and prior). Each is detected
         and calibrated by the real detectors and engine; the agent's session machine decides
         when its collection ends (short of 50 pairs with boards or 20 boards when the drive or
         the 120 s of still poses end: counted apart, not judged);
         per fault and overall: accepted within tolerance, false accepts (`updated` or `verified`
         beyond the accuracy a result must be known to, 0.3 deg or 3 cm), false rejects (clean
         sessions refused), refusals and their reason codes. Deterministic per seed. Fails on
         any false accept.
  --sessions N        sessions (default 400; 2000 for the full campaign)
  --quick             sessions whose collection ends at 80 pairs with boards (80-pair drives,
                      still poses of 6 sweeps) instead of at the agent's target (200 pairs;
                      200-pair drives, 10 sweeps a pose)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --threads N         recordings at once (default 2; the sessions sharing a round's clean
                      recording are one)
  --only LIST         only these sessions (comma-separated indices, as in --json): to look
                      again at one
  --faults LIST       only the sessions of these faults among them (comma-separated names, as
                      in the tables: none, camera_delay_stamped, ...; `--faults none`: the
                      clean sessions alone, the false rejects' measure)
  --unshared          each session simulated and detected on its own, none from its round's
                      clean recording (the same answers, slower: a check of the sharing)
  --json FILE         also write every session as JSON

time-offset the camera's time offset against the LiDAR, estimated by the engine from the boards'
         motion, over the default drive (3 boards, 6-30 m and back, 20 s at 10 Hz) with the
         camera 0-100 ms late: stamped at its trigger, or each pair stamped with its LiDAR
         sweep's time (pairs matched by file name); and a drive only towards the boards, where
         the offset cannot be told from a translation. Per drive: the true and estimated offset
         (sigma), what the solution was corrected for, its error and the verdict.
  --lidar LIST        comma-separated models (default ot128,m1)
  --seed N            simulation seed (default 1; its kind: Seeds, below)
  --threads N         drives at once (default 2)
  --json FILE         also write every drive as JSON

Exit codes: 0 done, 1 failed, 2 bad option.
)";

// The Seeds paragraph of the help, from the one list of tuning seeds.
std::string SeedsHelp() {
  std::string seeds;
  for (const unsigned long long s : calibd::bench::kTuningSeeds)
    seeds += (seeds.empty() ? "" : ", ") + std::to_string(s);
  return "\nSeeds: " + seeds +
         " are tuning seeds, on which sessions are looked at and constants set; any other is\n"
         "held-out, run only to report (docs/error-bound.md). Every table names its seed and\n"
         "that seed's kind.\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cout << kHelp << SeedsHelp();
    return argc < 2 ? calibd::tools::kExitBadOption : 0;
  }
  calibd::bench::BenchCommandLine b;
  b.memory.agent_path = b.pipeline.agent_path = b.soak.agent_path = CALIBD_AGENT_EXE;
  b.soak.sim_path = CALIBD_SIM_EXE;
  std::string error;
  if (!calibd::bench::ParseBenchCommandLine(argc, argv, &b, &error)) {
    std::cerr << "calibd-bench: " << error << "\n";
    return calibd::tools::kExitBadOption;
  }
  if (b.help) {
    std::cout << kHelp << SeedsHelp();
    return 0;
  }
  const std::string& c = b.command;
  if (c == "resolution") return calibd::bench::RunResolutionBench(b.resolution);
  std::ostream& out = std::cout;
  std::ostream* progress = &std::cerr;
  using namespace calibd::bench;
  const bool ok = c == "time-offset"    ? RunTimeOffsetBench(b.time_offset, out, progress, &error)
                  : c == "verdicts"     ? RunVerdictsBench(b.verdicts, out, progress, &error)
                  : c == "recordings"   ? RunRecordingsBench(b.recordings, out, progress, &error)
                  : c == "soak"         ? RunSoakBench(b.soak, out, progress, &error)
                  : c == "agent-memory" ? RunAgentMemoryBench(b.memory, out, progress, &error)
                  : c == "pipeline"     ? RunPipelineBench(b.pipeline, out, progress, &error)
                  : c == "calib"        ? RunCalibBench(b.calib, out, progress, &error)
                                        : RunDetectBench(b.detect, out, progress, &error);
  if (!ok) {
    std::cerr << "calibd-bench: " << error << "\n";
    return 1;
  }
  return 0;
}
