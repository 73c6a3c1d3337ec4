// common.hpp -- what the C++ peers share: the EzyRoller's parameters
// (docs/physics.md Sec. 10.1, 10.3), the reference final state, the
// error measure, the timing and the CSV line.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ezyroller {

// docs/physics.md Sec. 10.1
constexpr double a = 0.2, b = 0.6, c = 0.1, d = 0.1;
constexpr double m1 = 46.0, I1 = 10.0, m2 = 1.0, I2 = 0.005;
// the drive scene, Sec. 10.3: tau(t) = M0 cos(omega t), 60 s from rest
constexpr double M0 = 2.0;
constexpr double omega = 3.14159265358979323846;
constexpr double t_end = 60.0;
constexpr double pi = 3.14159265358979323846;

inline double torque(double t) { return M0 * std::cos(omega * t); }

// The reference: q (6), qd (6), W at t = 60 s, from reference.csv (lines
// starting with '#' are comments, then a header line, then one row).
inline std::array<double, 13> load_reference(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot read the reference %s\n", path.c_str());
    std::exit(2);
  }
  std::string line, header;
  std::vector<std::string> names;
  std::vector<double> values;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string cell;
    if (names.empty()) {
      while (std::getline(ss, cell, ',')) names.push_back(cell);
    } else {
      while (std::getline(ss, cell, ',')) values.push_back(std::strtod(cell.c_str(), nullptr));
      break;
    }
  }
  const char* want[13] = {"x1", "y1", "phi1", "x2", "y2", "phi2", "x1d",
                          "y1d", "phi1d", "x2d", "y2d", "phi2d", "W"};
  std::array<double, 13> r{};
  for (int k = 0; k < 13; ++k) {
    auto it = std::find(names.begin(), names.end(), want[k]);
    if (it == names.end() || static_cast<std::size_t>(it - names.begin()) >= values.size()) {
      std::fprintf(stderr, "reference %s has no column %s\n", path.c_str(), want[k]);
      std::exit(2);
    }
    r[k] = values[it - names.begin()];
  }
  return r;
}

// max over the 12 components of q and qd of |y - y_ref| (W is not counted)
inline double state_error(const std::array<double, 13>& y, const std::array<double, 13>& ref) {
  double e = 0.0;
  for (int k = 0; k < 12; ++k) e = std::max(e, std::fabs(y[k] - ref[k]));
  return e;
}

struct Args {
  double rtol = 1e-10, atol = -1.0;  // atol < 0: atol = rtol
  int reps = 21;
  double every = 0.0;  // > 0: dense output every `every` s (the reduced peer)
  std::string ref = "reference.csv";
  bool no_projection = false;
  bool print_state = false;
};

inline Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string s = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", s.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (s == "--rtol") a.rtol = std::atof(next());
    else if (s == "--atol") a.atol = std::atof(next());
    else if (s == "--reps") a.reps = std::atoi(next());
    else if (s == "--every") a.every = std::atof(next());
    else if (s == "--ref") a.ref = next();
    else if (s == "--no-projection") a.no_projection = true;
    else if (s == "--print-state") a.print_state = true;
    else {
      std::fprintf(stderr,
                   "usage: %s [--rtol R] [--atol A (default R)] [--reps N] [--ref reference.csv]"
                   " [--no-projection] [--print-state] [--every E]\n",
                   argv[0]);
      std::exit(2);
    }
  }
  if (a.atol < 0.0) a.atol = a.rtol;
  if (a.reps < 1) a.reps = 1;
  return a;
}

// Runs `once` (which integrates 0..60 s and returns the final state and
// the RHS count) `reps` times; returns the median wall time of one run.
template <class Once>
double median_time(int reps, Once&& once) {
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    once();
    const auto t1 = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double>(t1 - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

inline void print_line(const char* tool, const char* formulation, double rtol, long evals,
                       double seconds, double error) {
  std::printf("%s,%s,%.0e,%ld,%.6e,%.3e\n", tool, formulation, rtol, evals, seconds, error);
}

inline void print_state(const std::array<double, 13>& y, const std::array<double, 13>& ref) {
  const char* n[13] = {"x1", "y1", "phi1", "x2", "y2", "phi2", "x1d",
                       "y1d", "phi1d", "x2d", "y2d", "phi2d", "W"};
  for (int k = 0; k < 13; ++k)
    std::fprintf(stderr, "%-6s % .16e  ref % .16e  diff % .3e\n", n[k], y[k], ref[k], y[k] - ref[k]);
}

// Ends a peer's main(): DOP853's failure, or the CSV line (and, with
// --print-state, the final state against the reference); the exit status.
inline int report(const Args& args, const std::array<double, 13>& ref, int status, const char* formulation,
                  long evals, double seconds, const std::array<double, 13>& y) {
  if (status != 1) {
    std::fprintf(stderr, "dop853 failed: %d\n", status);
    return 1;
  }
  if (args.print_state) print_state(y, ref);
  print_line("C++ hand-written (dop853.hpp)", formulation, args.rtol, evals, seconds, state_error(y, ref));
  return 0;
}

}  // namespace ezyroller
