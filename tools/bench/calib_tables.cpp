#include "calib_tables.hpp"

#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <ostream>
#include <set>
#include <sstream>

#include "paper_figures.hpp"

namespace calibd::bench {

namespace {

std::string Fixed(double v, int precision) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

/// A figure over drives, or the reason code of a drive that gave no estimate (never a silent
/// number). With `mark_gated`, '!' marks figures that include estimates a post-solve gate
/// rejected.
std::string Figure(const Summary& s, double value, int precision, bool mark_gated = true) {
  if (!s.complete()) return s.missing_reason.empty() ? "-" : s.missing_reason;
  return Fixed(value, precision) + (mark_gated && s.gated > 0 && std::isfinite(value) ? "!" : "");
}

/// A label and right-aligned cells, at least one space between cells.
void Row(std::ostream& out, const std::string& label, const std::vector<std::string>& cells,
         int width = 13) {
  out << std::left << std::setw(16) << label << std::right;
  for (const auto& c : cells) out << ' ' << std::setw(width - 1) << c;
  out << "\n";
}

/// Explains a table's cells that Figure() replaced (one line each) or marked '!' (one line).
class TableNotes {
 public:
  void Add(const std::string& what, const Summary& s) {
    if (s.estimates < s.runs) {
      missing_.push_back(what + ": " + std::to_string(s.runs - s.estimates) + " of " +
                         std::to_string(s.runs) +
                         " runs stopped without an estimate (first: " + s.missing_reason + ")");
    } else if (s.gated > 0) {
      gated_ = true;
      gate_reasons_.insert(s.gate_reason);
    }
  }
  void Print(std::ostream& out) const {
    for (const auto& m : missing_) out << "  note: " << m << "\n";
    if (!gated_) return;
    std::string reasons;
    for (const auto& r : gate_reasons_) reasons += (reasons.empty() ? "" : ", ") + r;
    out << "  note: '!' marks figures counting estimates whose outcome a post-solve gate rejected ("
        << reasons << "); the JSON gives every run's verdict\n";
  }

 private:
  std::vector<std::string> missing_;
  bool gated_ = false;
  std::set<std::string> gate_reasons_;
};

void PrintAccuracy(const CalibBenchOptions& o, const std::vector<LidarResults>& results,
                   std::ostream& out) {
  out << "\n1. Accuracy of the default direct method over " << o.trajectories << " trajectories of "
      << o.frames << " pairs (a target is met when the worst trajectory meets it)\n";
  Row(out, "lidar",
      {"rot mean deg", "rot max deg", "target", "met", "trans mean m", "trans max m", "target",
       "met"});
  TableNotes notes;
  for (const auto& r : results) {
    const Summary s = Summarise(r.accuracy);
    const bool rot_met = s.complete() && s.rotation_max_deg <= kRotationTargetDeg;
    const bool trans_met = s.complete() && s.translation_max_m <= kTranslationTargetM;
    Row(out, r.lidar,
        {Figure(s, s.rotation_mean_deg, 4), Figure(s, s.rotation_max_deg, 4),
         Fixed(kRotationTargetDeg, 3), rot_met ? "met" : "not met",
         Figure(s, s.translation_mean_m, 4), Figure(s, s.translation_max_m, 4),
         Fixed(kTranslationTargetM, 3), trans_met ? "met" : "not met"});
    notes.Add(r.lidar, s);
  }
  notes.Print(out);
  out << "\n   Timing, median over trajectories (paper: 200 pairs on an i7-10750H)\n";
  Row(out, "lidar", {"grid ms", "target", "paper", "met", "optimise ms", "target", "paper", "met"});
  for (const auto& r : results) {
    const Summary s = Summarise(r.accuracy);
    Row(out, r.lidar,
        {Figure(s, s.grid_median_ms, 1, false), Fixed(kGridTargetMs, 0), Fixed(kPaperGridMs, 0),
         s.complete() && s.grid_median_ms <= kGridTargetMs ? "met" : "not met",
         Figure(s, s.optimise_median_ms, 1, false), Fixed(kOptimiseTargetMs, 0),
         Fixed(kPaperOptimiseMs, 0),
         s.complete() && s.optimise_median_ms <= kOptimiseTargetMs ? "met" : "not met"});
  }
}

/// One Table I: rows alpha, a column per LiDAR (with the paper's beside it when `paper`).
void PrintAlphaTable(const std::vector<LidarResults>& results, bool indirect, bool paper,
                     std::ostream& out) {
  std::vector<std::string> header;
  for (const auto& r : results) {
    header.push_back(r.lidar);
    if (paper) header.push_back(PaperColumn(r.lidar) ? PaperColumn(r.lidar)->vendor : "paper");
  }
  Row(out, "alpha (m)", header);
  if (results.empty()) return;
  // Best alpha per column: ours among complete rows, the paper's among its rows.
  const size_t rows = results.front().alphas.size();
  std::vector<size_t> best(results.size(), rows), paper_best(results.size(), rows);
  for (size_t c = 0; c < results.size(); ++c) {
    double lo = std::numeric_limits<double>::infinity(), paper_lo = lo;
    for (size_t a = 0; a < rows; ++a) {
      const auto& row = results[c].alphas[a];
      const Summary s = Summarise(indirect ? row.indirect : row.direct);
      if (s.complete() && s.reprojection_mean_px < lo) {
        lo = s.reprojection_mean_px;
        best[c] = a;
      }
      const double p = PaperTableI(PaperColumn(results[c].lidar), row.alpha_m);
      if (p < paper_lo) {  // false for NaN
        paper_lo = p;
        paper_best[c] = a;
      }
    }
  }
  TableNotes notes;
  for (size_t a = 0; a < rows; ++a) {
    std::vector<std::string> cells;
    const double alpha = results.front().alphas[a].alpha_m;
    for (size_t c = 0; c < results.size(); ++c) {
      const auto& row = results[c].alphas[a];
      const Summary s = Summarise(indirect ? row.indirect : row.direct);
      cells.push_back(Figure(s, s.reprojection_mean_px, 3) + (best[c] == a ? "*" : " "));
      if (paper)
        cells.push_back(Fixed(PaperTableI(PaperColumn(results[c].lidar), alpha), 3) +
                        (paper_best[c] == a ? "*" : " "));
      notes.Add(results[c].lidar + " alpha " + Fixed(alpha, 2), s);
    }
    Row(out, Fixed(alpha, 2), cells);
  }
  notes.Print(out);
}

void PrintBands(const CalibBenchOptions& o, const LidarResults& r, std::ostream& out) {
  out << "\n3. Table II analogue, " << r.lidar << ": STD (deg) over " << o.trajectories
      << " trajectories of the rotation error about the LiDAR axes (x roll, y pitch, z yaw)\n"
      << "   using only boards close to or far from the camera; the paper's dataset is not named "
         "and its angles are Euler angles\n";
  Row(out, "", {"indirect", "direct", "direct+refine", "paper ind", "paper dir"}, 16);
  const char* axes[] = {"roll", "pitch", "yaw"};
  TableNotes notes;
  for (const auto& band : r.bands) {
    std::vector<Summary> s;
    for (const auto& runs : band.runs) s.push_back(Summarise(runs));
    out << "  " << band.name << " ("
        << (band.min_m > 0.0 ? "> " + Fixed(band.min_m, 1) : "< " + Fixed(band.max_m, 1))
        << " m): " << Fixed(s.front().frames_mean, 1) << " pairs, "
        << Fixed(s.front().camera_boards_mean, 1) << " camera boards per trajectory\n";
    for (int axis = 0; axis <= 3; ++axis) {  // 3: the mean of the three
      std::vector<std::string> cells;
      for (const auto& sm : s)
        cells.push_back(Figure(sm, axis < 3 ? sm.std_rpy_deg(axis) : sm.std_rpy_deg.mean(), 3));
      for (int m = 0; m < 2; ++m) {
        const double* p = kPaperTableII[band.name == "close" ? 0 : 1][m];
        cells.push_back(Fixed(axis < 3 ? p[axis] : (p[0] + p[1] + p[2]) / 3.0, 3));
      }
      Row(out, std::string("  ") + band.name + " " + (axis < 3 ? axes[axis] : "mean"), cells, 16);
    }
    for (size_t m = 0; m < s.size(); ++m)
      notes.Add(band.name + std::string(" ") + MethodName(kMethods[m]), s[m]);
  }
  notes.Print(out);
}

void PrintSampling(const CalibBenchOptions& o, const LidarResults& r, std::ostream& out) {
  out << "\n4. Fig. 7 analogue, " << r.lidar << ": mean of the roll/pitch/yaw STDs (deg) over "
      << o.trajectories
      << " trajectories; a pair is kept when the vehicle moved >= d since the last kept pair "
         "(the paper gives a plot only)\n";
  Row(out, "d (m)", {"pairs kept", "indirect", "direct", "direct+refine"}, 16);
  TableNotes notes;
  for (const auto& row : r.sampling) {
    std::vector<std::string> cells;
    for (size_t m = 0; m < row.runs.size(); ++m) {
      const Summary s = Summarise(row.runs[m]);
      if (m == 0) cells.push_back(Fixed(s.frames_mean, 1));
      cells.push_back(Figure(s, s.std_rpy_deg.mean(), 3));
      notes.Add("d " + Fixed(row.min_step_m, 1) + " " + MethodName(kMethods[m]), s);
    }
    Row(out, Fixed(row.min_step_m, 1), cells, 16);
  }
  notes.Print(out);
}

/// "no_grid_candidate 3, > 0.2 deg 1": why trials did not converge.
std::string Failures(const GridTrials& g, const std::vector<ScoredRun>& runs) {
  std::map<std::string, int> count;
  for (const auto& r : runs) {
    if (!r.has_estimate)
      ++count[r.reason];
    else if (r.rotation_error_deg >= g.converged_deg)
      ++count["> " + Fixed(g.converged_deg, 1) + " deg"];
  }
  std::string s;
  for (const auto& [why, n] : count) s += (s.empty() ? "" : ", ") + why + " " + std::to_string(n);
  return s.empty() ? "none" : s;
}

void PrintGridTrials(const CalibBenchOptions& o, const std::vector<LidarResults>& results,
                     std::ostream& out) {
  if (o.trials <= 0) return;
  out << "\n5. Grid search (paper IV-D): first trajectory, " << o.trials
      << " priors = truth rotated by roll/pitch/yaw uniform in +-10 deg; converged: rotation "
         "error < 0.2 deg after optimisation\n";
  Row(out, "lidar", {"with search", "paper", "without", "paper"});
  const std::string paper_with =
      std::to_string(kPaperConvergedWith) + "/" + std::to_string(kPaperTrials);
  const std::string paper_without =
      std::to_string(kPaperConvergedWithout) + "/" + std::to_string(kPaperTrials);
  for (const auto& r : results) {
    const auto& g = r.grid;
    const std::string n = "/" + std::to_string(g.with_search.size());
    Row(out, r.lidar,
        {std::to_string(g.converged_with) + n, paper_with, std::to_string(g.converged_without) + n,
         paper_without});
  }
  for (const auto& r : results)
    out << "  " << r.lidar
        << " not converged: with search: " << Failures(r.grid, r.grid.with_search)
        << "; without: " << Failures(r.grid, r.grid.without_search) << "\n";
}

}  // namespace

void PrintCalibTables(const CalibBenchOptions& o, const std::vector<LidarResults>& results,
                      std::ostream& out) {
  PrintAccuracy(o, results, out);
  out << "\n2. Table I analogue: mean reprojection error (px) of LiDAR-fitted tag corners against "
         "the camera's, indirect method, mean over "
      << o.trajectories << " trajectories (* best alpha per column)\n";
  PrintAlphaTable(results, true, true, out);
  out << "\n   The same with the direct method (default: board-pose refinement)\n";
  PrintAlphaTable(results, false, false, out);
  for (const auto& r : results) PrintBands(o, r, out);
  for (const auto& r : results) PrintSampling(o, r, out);
  PrintGridTrials(o, results, out);
}

}  // namespace calibd::bench
