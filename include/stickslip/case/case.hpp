#pragma once
// The validated description of one run, parsed once from a TOML case file
// (see reader.hpp). Defaults are the paper's values (MODEL.md §10), so a case
// file lists only what differs. All units SI.

#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace stickslip {

enum class GradDiv { paper, navier };       // G2 = (1+2ν) G1 (paper) or G1/(1−2ν) (Navier)
enum class InitialState { rest, sliding };  // u = w = 0, or w^x = v everywhere
// imex: ARKStep additive RK, contacts implicit (exact per-contact stage solve);
// dirk: ARKStep fully implicit; bdf: CVODE; erk: ARKStep explicit; rk4: the
// classic fourth-order Runge–Kutta at a fixed step; multirate: ESDIRK with
// fast contacts on sub-steps of their own (case/methods.cpp has every row).
enum class Method { imex, dirk, bdf, erk, rk4, multirate, automatic };
// How dirk and bdf solve their stage equations: "fft" (= "auto") solves each
// exactly (the lattice by FFT in x, y and banded solves along z, the contacts
// by Newton on their coupled speeds). "klu" is refused by the reader, which
// says why (a sparse LU of the 3D lattice, docs/notes/performance-history.md).
enum class LinearSolver { automatic, fft };
enum class ContactSelection { all, none, list };  // which contacts an output covers
// The contact law ([interface] law): "paper", MODEL.md §6's φ(r) = exp(−c
// (log10 r)²). Each name is one law of model/friction_law.hpp (ContactLaws).
enum class ContactLawName { paper };
inline const char* to_string(ContactLawName law) {
  switch (law) {
    case ContactLawName::paper:
      return "paper";
  }
  return "?";
}

struct LatticeParams {
  int nx = 15;
  int ny = 15;
  int nz = 10;
  double spacing = 1e-4;  // a [m]
};

struct MaterialParams {
  double density = 1e3;         // ρ [kg/m³]
  double youngs_modulus = 1e7;  // E [Pa]
  double poisson_ratio = 0.5;   // ν
  GradDiv grad_div = GradDiv::paper;
};

struct DampingParams {
  double bulk = 0.1;     // η̂ = η/ω0
  double contact = 0.1;  // η̂_c = η_c/ω0
};

struct ExplicitContact {
  int ix = 0;
  int iy = 0;
  double v_star = 0.0;  // [m/s]
  int line = 0;         // where it was given in the case file, for error messages
};

struct InterfaceParams {
  ContactLawName law = ContactLawName::paper;
  double coverage = 0.1;  // θ requested; N_c = floor(θ Nx Ny + 0.5)
  std::uint64_t seed = 1;
  double shear_stress = 6.5e6;  // τ_f [Pa]
  double shape = 0.1;           // c in φ(r) = exp(−c (log10 r)²)
  double v_m = 1e-3;            // centre of the log-uniform v* distribution [m/s]
  double spread = 0.5;          // δ, half-width of log10 v* [decades]
  double epsilon = 1e-2;        // ε, force scaling
  double max_pressure = 1e6;    // P0 [Pa]
  double slip_threshold = 1.0;  // κ: slipping while |s| > κ v*
  // R: every contact is an R×R square of bottom nodes (MODEL.md §14); 1 is
  // the paper's single-site contact. N_c = floor(θ Nx Ny / R² + 0.5).
  int patch = 1;
  // A non-empty list replaces the random placement (coverage and seed unused).
  std::vector<ExplicitContact> contacts;
};

struct DriveParams {
  double velocity = 1e-3;  // v [m/s]
};

struct RunParams {
  double t_end = 5e-3;         // [s]
  double average_from = 1e-3;  // t_avg [s]: μ averages F_f over [t_avg, t_end]
  // average_from = "auto": t_avg is found at the end, where F_f's loading
  // transient ends (core/cycles.hpp's settled_from); average_from is 0 then.
  bool average_auto = false;
  InitialState initial = InitialState::rest;
  double checkpoint_every = 0.0;  // [s] of simulated time between checkpoints; 0: none
};

struct SolverParams {
  Method method = Method::automatic;                     // "auto": choose_method() picks
  LinearSolver linear_solver = LinearSolver::automatic;  // dirk and bdf only
  int order = 0;      // 0: the method's default (bdf: 2, see MODEL.md §12)
  double step = 0.0;  // > 0: fixed step [s], adaptivity off (ARKStep's methods)
  double rtol = 1e-6;
  // 0 (unset): rtol times the case's own scale (integrate/tolerances.hpp), so
  // that rtol alone controls the error.
  double atol_displacement = 0.0;  // [m]
  double atol_velocity = 0.0;      // [m/s]
  long max_steps = 50'000'000;     // over the whole run
  // method = "multirate": the fewest fast contacts it steps apart on their
  // own sub-steps; with fewer, one step follows them all (single rate),
  // since a single slip costs less so (docs/notes/performance-history.md, "Multirate");
  // after a step with contacts apart, an eighth as many (a block slip's tail).
  // A lone contact (at most one other contact around it) counts 8.
  long multirate_min_fast = 64;
  // Largest accepted |energy-audit residual| at t_end; 0: 100 × rtol, or
  // 1e-4 for a fixed step. Beyond it the run fails and reports no μ.
  double audit_bound = 0.0;
  // OpenMP threads of one run (1: serial; 0: every core the process may use
  // where the lattice is large enough to gain, resolved by resolved_threads).
  // Results do not depend on it, bit for bit; what it gains:
  // docs/PERFORMANCE.md, "Threads".
  int threads = 0;
};

// Below this many lattice nodes, [solver] threads = 0 means one thread: on
// 6×6×4 (144 nodes) two threads made dirk, bdf and imex 1.2–1.4× slower
// (their parallel loops too small to pay for waking a thread), while
// 10×10×10 gained 1.33× and 15×15×10 1.3–1.4× (docs/notes/performance-history.md).
inline constexpr std::int64_t kMinNodesForThreads = 1000;

// [solver] threads with 0 resolved for a lattice of `nodes` nodes: OpenMP's
// thread count for the process (OMP_NUM_THREADS if set, else the cores it
// may run on), or 1 below kMinNodesForThreads. A count the case gives is
// kept as it is.
int resolved_threads(const SolverParams& solver, std::int64_t nodes);

// The files a run writes its tables to: one CSV file per table, or one HDF5
// file (run.h5) with a group per table.
enum class OutputFormat { csv, hdf5 };

struct OutputParams {
  std::filesystem::path dir;  // empty: out/<case file stem> in the working directory
  double interval = 1e-6;     // [s] between rows of friction.csv and traces.csv
  // The most rows t_end/interval may give a table: a guard against a typo
  // that would write for days (t_end = 1e9 s at 1 µs: 1e15 rows).
  long max_rows = 10'000'000;
  ContactSelection traces = ContactSelection::none;
  std::vector<int> trace_ids;                       // when traces == list
  ContactSelection events = ContactSelection::all;  // whose stick/slip transitions are located
  std::vector<int> event_ids;                       // when events == list
  bool steps = false;                               // write steps.csv
  bool attempts = false;  // write attempts.csv (a stepper whose attempts are its own: multirate)
  // write final_state.csv, and keep checkpoint.bin at t_end: a later
  // run.t_end can then continue the run (run --restart)
  bool final_state = false;
  bool signals = false;  // write signals.csv (block velocity, acoustic signal)
  OutputFormat format = OutputFormat::csv;
};

struct Case {
  std::filesystem::path source;  // the case file it was read from
  LatticeParams lattice;
  MaterialParams material;
  DampingParams damping;
  InterfaceParams interface;
  DriveParams drive;
  RunParams run;
  SolverParams solver;
  OutputParams output;
};

// The case as resolved (every parameter, defaults filled in), for summary.json:
// each key as its schema row writes it (case/reader.cpp).
nlohmann::json to_json(const Case& c);
// The same as the text of a case file, which reads back as this case (values
// that mean "unset", such as an empty output.dir, are left out; output.dir is
// made absolute, so the text may be saved anywhere).
std::string to_toml(const Case& c);

const char* to_string(GradDiv);
const char* to_string(InitialState);
const char* to_string(OutputFormat);

// The method whose rules (fixed step, orders, linear solver) a case is
// validated against: itself, or for "auto" imex. So "auto" allows a fixed
// step (it then runs imex), orders 3 to 5 and no [solver] linear_solver;
// without a fixed step it runs dirk, bdf or multirate (choose_method in
// integrate/make_integrator.hpp), whose rows allow adaptive steps and these
// orders too, but for multirate's, which stops at order 4.
Method validated_as(Method requested);

}  // namespace stickslip
