#pragma once
/// \file
/// The IsValid convention of every config struct and opener: false, with `error` (when given)
/// naming what is wrong. One helper for it, and one for the range checks, which never let a NaN
/// or an infinity through (`fy: .inf` is refused like `fy: .nan`).

#include <cmath>
#include <string>
#include <utility>

namespace calibd {

/// Sets *error (when given) to `message` and returns false: `return Invalid(error, "...")`.
inline bool Invalid(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

/// `v` is finite and greater than `lo`.
inline bool FiniteAbove(double v, double lo) { return std::isfinite(v) && v > lo; }
/// `v` is finite and at least `lo`.
inline bool FiniteAtLeast(double v, double lo) { return std::isfinite(v) && v >= lo; }

}  // namespace calibd
