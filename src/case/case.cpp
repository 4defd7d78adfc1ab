#include "stickslip/case/case.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#ifdef _OPENMP
#include <omp.h>
#endif

namespace stickslip {

const char* to_string(GradDiv g) {
  switch (g) {
    case GradDiv::paper:
      return "paper";
    case GradDiv::navier:
      return "navier";
  }
  return "?";
}

const char* to_string(InitialState s) {
  switch (s) {
    case InitialState::rest:
      return "rest";
    case InitialState::sliding:
      return "sliding";
  }
  return "?";
}

const char* to_string(OutputFormat f) {
  switch (f) {
    case OutputFormat::csv:
      return "csv";
    case OutputFormat::hdf5:
      return "hdf5";
  }
  return "?";
}

Method validated_as(Method requested) {
  return requested == Method::automatic ? Method::imex : requested;
}

int resolved_threads(const SolverParams& solver, std::int64_t nodes) {
  if (solver.threads > 0) return solver.threads;
  if (nodes < kMinNodesForThreads) return 1;
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

}  // namespace stickslip
