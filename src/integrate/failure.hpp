#pragma once
// Shared wording of integrator failures (private to src/integrate).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

// "; largest weighted local errors: 3.2 at w^x of node (4, 7, 0), ..." for
// the weighted local errors e, the three largest.
inline std::string largest_errors(const System& system, std::span<const double> e) {
  char buf[96];
  std::vector<std::size_t> order(e.size());
  std::iota(order.begin(), order.end(), 0);
  const std::size_t shown = std::min<std::size_t>(3, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(shown), order.end(),
                    [&](auto a, auto b) { return std::abs(e[a]) > std::abs(e[b]); });
  std::string msg = "; largest weighted local errors:";
  for (std::size_t k = 0; k < shown; ++k) {
    std::snprintf(buf, sizeof buf, "%s %.3g at ", k ? "," : "", std::abs(e[order[k]]));
    msg += buf + system.describe_component(static_cast<std::int64_t>(order[k]));
  }
  return msg;
}

// "<call> failed at t = ... s: <flag>: <SUNDIALS' message>; largest weighted local errors: 3.2
// at w^x of node (4, 7, 0), ..."
inline std::string describe_failure(const System& system, const char* call,
                                    const std::string& flag_name, const std::string& said, double t,
                                    N_Vector error, N_Vector weights, bool have_errors) {
  char buf[96];
  std::snprintf(buf, sizeof buf, " failed at t = %.9g s: ", t);
  std::string msg = std::string(call) + buf + flag_name;
  if (!said.empty()) msg += ": " + said;
  if (!have_errors) return msg;
  N_VProd(error, weights, error);
  return msg + largest_errors(system, as_span(error));
}

// The run used up [solver] max_steps. Which components limit the step is not
// known here (the last local error estimate belongs to an accepted step), so
// the message gives where it stopped and how small the steps had become.
inline std::string describe_out_of_steps(double t, long steps, double last_step) {
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "stopped at t = %.9g s after %ld steps: more than [solver] max_steps (last step "
                "%.3g s)",
                t, steps, last_step);
  return buf;
}

}  // namespace stickslip
