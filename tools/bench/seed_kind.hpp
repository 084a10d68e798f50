#pragma once
/// \file
/// Held-out evaluation: which simulation seeds the team tunes on and which it only reports on.
/// On a tuning seed, sessions may be looked at and constants (gates, descriptors, defaults) set
/// from them; a held-out seed is run only to report, and every figure in the docs about false
/// accepts, false rejects or coverage comes from one, named. When a held-out run finds a fault
/// that needs a fix, the fix is reported again on a seed not run before. The benchmarks print
/// each seed's kind beside it.

#include <algorithm>
#include <iterator>
#include <string>

namespace calibd::bench {

/// Every seed the team has looked at in any benchmark: 1 (every gate of the fault campaign was
/// first set on it), 1-5 (`calibd-bench calib`'s five drives, `recordings` seeds 1-4, `detect`
/// seeds 1-2, on which detector and solver constants were chosen), 7 (the campaign's clean
/// sessions compared one by one while the engine was reorganised), and 15 (held-out until its
/// session 6, a false accept, was studied to fix it: the error bound's unbiased reading of the
/// principal point, reported on seeds 16 and 17; VerdictsBenchTest runs that session), and 22
/// (held-out for its 2000-session run at 79d7c53, whose false accept, session 1363, was studied
/// to fix it: kMaxStatedSharpening, reported on held-out seeds 23 and 24), and 24 (held-out for
/// its 1000-session run at a97b74d, whose VLP-16 still poses lay outside their translation bound:
/// studied to fix it, the fix reported on a seed not run before).
inline constexpr unsigned long long kTuningSeeds[] = {1, 2, 3, 4, 5, 7, 15, 22, 24};

/// The held-out seed `make test` runs (VerdictsBenchTest.HeldOutCleanSessionsLieInsideTheirBounds):
/// no constant is set on it, and no figure in the docs comes from it. Should the test fail, the
/// cause is fixed and the test moves to a seed not run before.
inline constexpr unsigned long long kHeldOutTestSeed = 101;

inline bool IsTuningSeed(unsigned long long seed) {
  return std::find(std::begin(kTuningSeeds), std::end(kTuningSeeds), seed) !=
         std::end(kTuningSeeds);
}

/// "tuning" or "held-out", as the benchmarks' tables and JSON name it.
inline const char* SeedKind(unsigned long long seed) {
  return IsTuningSeed(seed) ? "tuning" : "held-out";
}

/// "seed 11, held-out" for a table's heading.
inline std::string SeedLabel(unsigned long long seed) {
  return "seed " + std::to_string(seed) + ", " + SeedKind(seed);
}

}  // namespace calibd::bench
