#include "stickslip/integrate/multirate_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

#include "failure.hpp"
#include "stickslip/integrate/tolerances.hpp"

namespace stickslip {

struct MultirateIntegrator::Step {
  double t0 = 0.0, H = 0.0;
  // Coarse values and derivatives at both ends (the cubic Hermite of every
  // component; the fast contacts' in-plane u, w are their sub-steps' instead).
  std::vector<double> y0, f0, y1, f1;
  std::vector<std::size_t> fast;    // sites
  std::vector<SubstepResult> fine;  // per fast site
  // Each fast contact's stand-in in the coarse step: line0 + line1 τ, less the
  // node's own K u + C w along its coarse path where attempt cancels them.
  std::vector<std::array<double, 2>> line0, line1;
  double error = 0.0;
  double miss = 0.0;  // the hand-back's at acceptance (0 with no contact apart)
  // The stand-ins' work on their coarse paths plus the contacts' dissipation
  // on their sub-steps [J] (SolverStats::partition_work).
  double partition_work = 0.0;
};

// Φ of each fast contact splits into what the coarse level gives (slow
// components: a polynomial through its stages) and its fast neighbours'
// in-plane motion, read off their sub-steps: a fast neighbour's coarse
// stand-in has its impulse, not its timing.
struct MultirateIntegrator::Coupling {
  struct Entry {
    int row;
    double coefficient;
    std::int64_t column;
  };
  struct FastEntry {
    int row;
    double coefficient;
    std::size_t other;  // the fast contact it reads
    int component;      // of the other's x: u_x, u_y, w_x, w_y
  };
  std::vector<std::vector<Entry>> slow;      // per fast contact
  std::vector<std::vector<FastEntry>> fast;  // per fast contact
};

// One attempt at a coarse step: the step being tried (Step) and what the
// passes of its coupling hand from one to the next. It lives as long as the
// attempt; the stage values it refers to (z_, f_) are the integrator's
// workspace, rewritten by the next attempt.
struct MultirateIntegrator::Attempt {
  Step& st;
  double H;
  std::vector<char> is_fast;      // per site
  std::vector<double> stage_tau;  // the stages' times in the step
  Coupling coupling;
  bool cancel_own;  // the stand-ins cancel their node's own K and C (attempt)
  ContactSubsteps substeps;
  // Two sets of sub-steps: the last pass's, which this pass's Φ reads, and
  // this pass's (fine[pass % 2]).
  std::array<std::vector<SubstepResult>, 2> fine;
  std::vector<Forcing> forcing, next_forcing;  // per fast contact: this pass's Φ, the next's
  // The coarse node's end displacement is what the coarse level gives it
  // (u0 + w0 H, Φ along the stages, and, where its own K and C are not
  // cancelled, those along its path) plus its line's H A0 − A1. The first
  // line takes A1 from the sub-steps; the coarse level's part then differs
  // from theirs (they moved under the last pass's Φ), and the coarse node
  // misses their end by δu. Each later line sets A1 so that the coarse
  // level's part of the last pass (`coarse_part`) plus the line lands on
  // these sub-steps' end. A stuck contact takes a change of Φ up in its
  // friction: its sub-steps' end hardly moves, but their moments do, so a
  // line shifted by the last miss alone counted that change twice, came back
  // with the miss's sign flipped, and the miss then set the coarse step
  // (60x60x10 at θ = 0.04: ~8e-8 s, docs/notes/performance-history.md).
  std::vector<std::array<double, 2>> coarse_part, line_part;
  // For the attempts table: the last pass's hand-back measures and the
  // component that decided the verdict.
  int pass = 0;
  double coupling_error = std::numeric_limits<double>::quiet_NaN();
  double miss = std::numeric_limits<double>::quiet_NaN();
  std::int64_t worst = -1;

  std::vector<SubstepResult>& current() { return fine[static_cast<std::size_t>(pass % 2)]; }
};

namespace {

// The state index of site j's u_x and w_x.
std::int64_t u_of(const System& s, std::size_t j) {
  return s.u_index(s.contact_set().sites()[j].node, 0);
}
std::int64_t w_of(const System& s, std::size_t j) {
  return s.w_index(s.contact_set().sites()[j].node, 0);
}

std::int64_t largest(std::span<const double> v) {
  std::size_t worst = 0;
  for (std::size_t r = 0; r < v.size(); ++r)
    if (std::abs(v[r]) > std::abs(v[worst])) worst = r;
  return static_cast<std::int64_t>(worst);
}

}  // namespace

MultirateIntegrator::MultirateIntegrator(const System& system, const SolverParams& solver,
                                         std::span<const double> y0, double t0, double t_stop,
                                         IntegratorOptions options)
    : system_(system),
      solver_(solver),
      options_(std::move(options)),
      table_(esdirk_table(solver.order)),
      couplings_(node_couplings(system)),
      atol_(absolute_tolerances(system, solver)),
      // A fast contact is held to γλ ≤ 1 by its own sub-steps; a slow one
      // that exceeds it turns fast (attempt). The contacts' Newton steps by
      // dirk's rule (LatticeStageSolver::uses_dense_lu): on 30x30x10 the
      // matrix-free steps, forced, took twice the dense LU's CPU in a block
      // slip (3.4 M Krylov iterations against 7 885), but on 60x60x10 (1 793
      // sites) the dense LU's solves and factorizations took 77 % of a
      // block slip's time and the matrix-free steps went twice as fast
      // (docs/notes/performance-history.md, "Multirate at 60×60").
      stages_(system, LatticeStageSolver::kMaxGammaLambda,
              LatticeStageSolver::ContactNewton::by_count, options_.threads),
      partition_(system, solver.multirate_min_fast),
      n_(y0.size()),
      t_stop_(t_stop),
      poll_steps_(poll_steps(Method::multirate, solver.linear_solver)),
      t_(t0),
      y_(y0.begin(), y0.end()),
      lattice_f_(n_),
      contact_a_(system.contact_set().sites().size()),
      h_(0.0),
      substep_(system.contact_set().sites().size(), 0.0),
      t_reached_(t0),
      b_(n_),
      weights_(n_),
      error_(n_),
      f_(static_cast<std::size_t>(table_.stages), std::vector<double>(n_)),
      z_(static_cast<std::size_t>(table_.stages), std::vector<double>(n_)) {
  if (system.contact_set().patch() != 1)
    throw std::invalid_argument("method = \"multirate\" steps single-site contacts (patch = 1)");
  // At the start a_c is the law's: the one time it is evaluated at a state
  // rather than taken from a stage (as ARKStep's first f for dirk).
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    const auto wx = w_of(system_, j);
    contact_a_[j] = system_.contact_set().site_acceleration(j, {y_[wx], y_[wx + 1]});
  }
  begin_step_derivative();
  roots_.assign(options_.watched_contacts.size(), 0);
  peaks_ = SpeedPeaks(roots_.size());
  sign_.resize(roots_.size());
  std::vector<double> g(roots_.size());
  system_.contact_set().stick_slip_roots(y_, options_.watched_contacts, g);
  for (std::size_t k = 0; k < g.size(); ++k) sign_[k] = g[k] > 0.0 ? 1 : -1;
  // The first step: small against any time scale of the model (the contacts'
  // own ~1e-9 s near their peak); the controller grows it 5× a step.
  h_ = std::min(1e-10, 0.5 * (t_stop - t0));
}

MultirateIntegrator::~MultirateIntegrator() = default;

// The lattice's part of f at (t_, y_): u' = w, a_L, and the quadratures' rates
// without the contacts' dissipation (added per site, with the a_c the step uses).
void MultirateIntegrator::begin_step_derivative() {
  system_.rhs_explicit(t_, y_, lattice_f_, loop_threads(options_));
  lattice_f_[system_.quadrature_index(System::dissipated)] = system_.lattice_dissipation(y_);
  ++stats_.rhs_explicit;
}

// One attempt at a coarse step of size H: the header's steps 1–5. `retry`:
// the outcome of the attempt it repeats at the same H, which set its
// partition (and, where it solved every stage, its first Φ).
MultirateIntegrator::Outcome MultirateIntegrator::attempt(double H, std::optional<Outcome> retry) {
  if (!trial_) trial_ = std::make_unique<Step>();
  Step& st = *trial_;
  begin_attempt(st, H,
                retry ? std::move(retry->retry_fast)
                      : partition_.fast_contacts(H, y_, lattice_f_, contact_a_,
                                                 step_ && !step_->fast.empty()));
  const std::size_t nf = st.fast.size();
  const auto n3 = static_cast<std::size_t>(3 * system_.num_nodes());
  Attempt a{st,
            H,
            std::vector<char>(contact_a_.size(), 0),
            std::vector<double>(static_cast<std::size_t>(table_.stages)),
            couple(st.fast),
            cancels_own(H, st.fast),
            ContactSubsteps(system_, table_, solver_.rtol,
                            {atol_[0], atol_[1], atol_[n3], atol_[n3 + 1]}),
            {std::vector<SubstepResult>(nf), std::vector<SubstepResult>(nf)},
            std::vector<Forcing>(nf),
            std::vector<Forcing>(nf),
            std::vector<std::array<double, 2>>(nf, {0.0, 0.0}),
            std::vector<std::array<double, 2>>(nf, {0.0, 0.0})};
  for (const std::size_t j : st.fast) a.is_fast[j] = 1;
  for (std::size_t i = 0; i < a.stage_tau.size(); ++i) a.stage_tau[i] = table_.c[i] * H;
  // The first Φ: where an attempt at this same step has just solved every
  // stage (a retry after a slow contact turned fast), the polynomial through
  // Φ along those stages; otherwise its Taylor line at the step's start.
  if (retry && !retry->retry_forcing.empty()) {
    a.forcing = std::move(retry->retry_forcing);
  } else {
    for (std::size_t q = 0; q < nf; ++q) {
      const NodeCoupling& c = couplings_[st.fast[q]];
      a.forcing[q] = Forcing::taylor(H, c.forcing(st.y0.data()), c.forcing(st.f0.data()));
    }
  }
  for (a.pass = 0; a.pass < kCouplingIterations; ++a.pass) {
    std::optional<Outcome> o = substep_fast(a);
    if (!o) o = coarse_stages(a);
    if (!o) o = check_error(a);
    if (!o) o = hand_back(a);
    if (o) {
      report(a, *o);
      return std::move(*o);
    }
    ++counts_.coupling_iterations;
    std::swap(a.forcing, a.next_forcing);  // reads this pass's sub-steps, which the next keeps
  }
  Outcome o{AttemptRecord::Verdict::shrink_coupling, "Φ did not settle", {}, {}};
  a.pass = kCouplingIterations - 1;
  report(a, o);
  return o;
}

// The step's start: its partition, f there (the lattice's part, each site's
// a_c, and the slow contacts' dissipation: the fast ones' is their
// sub-steps'), and the error weights.
void MultirateIntegrator::begin_attempt(Step& st, double H, std::vector<std::size_t> fast) {
  const double m = system_.mass();
  st.t0 = t_;
  st.H = H;
  st.y0 = y_;
  st.error = std::numeric_limits<double>::quiet_NaN();
  st.miss = 0.0;
  st.fast = std::move(fast);
  st.line0.assign(st.fast.size(), {});
  st.line1.assign(st.fast.size(), {});
  std::vector<char> is_fast(contact_a_.size(), 0);
  for (const std::size_t j : st.fast) is_fast[j] = 1;
  st.f0 = lattice_f_;
  const auto diss = system_.quadrature_index(System::dissipated);
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    const auto wx = w_of(system_, j);
    st.f0[wx] += contact_a_[j][0];
    st.f0[wx + 1] += contact_a_[j][1];
    if (!is_fast[j]) st.f0[diss] -= m * (contact_a_[j][0] * y_[wx] + contact_a_[j][1] * y_[wx + 1]);
  }
  for (std::size_t i = 0; i < n_; ++i)
    weights_[i] = 1.0 / (solver_.rtol * std::abs(y_[i]) + atol_[i]);
}

// Each fast contact's Φ: its node's coupling row, split into the columns
// of slow components and those of a fast neighbour's in-plane motion.
MultirateIntegrator::Coupling MultirateIntegrator::couple(
    const std::vector<std::size_t>& fast) const {
  const std::size_t nf = fast.size();
  Coupling out{std::vector<std::vector<Coupling::Entry>>(nf),
               std::vector<std::vector<Coupling::FastEntry>>(nf)};
  // Each bottom node's fast contact, if any (sites are bottom nodes).
  const std::int64_t layer = std::int64_t{system_.nx()} * system_.ny();
  std::vector<long> fast_at(static_cast<std::size_t>(layer), -1);
  for (std::size_t q = 0; q < nf; ++q)
    fast_at[static_cast<std::size_t>(system_.contact_set().sites()[fast[q]].node)] =
        static_cast<long>(q);
  const auto N3 = 3 * system_.num_nodes();
  for (std::size_t q = 0; q < nf; ++q) {
    const NodeCoupling& c = couplings_[fast[q]];
    for (int k = 0; k < 2; ++k)
      for (std::size_t e = 0; e < c.column[k].size(); ++e) {
        const std::int64_t col = c.column[k][e];
        const bool velocity = col >= N3;
        const std::int64_t index = velocity ? col - N3 : col;  // 3 node + axis
        const std::int64_t node = index / 3;
        const int axis = static_cast<int>(index % 3);
        const long other =
            col < 2 * N3 && axis < 2 && node < layer ? fast_at[static_cast<std::size_t>(node)] : -1;
        if (other >= 0)
          out.fast[q].push_back(
              {k, c.value[k][e], static_cast<std::size_t>(other), (velocity ? 2 : 0) + axis});
        else
          out.slow[q].push_back({k, c.value[k][e], col});
      }
  }
  return out;
}

// The stand-in cancels the node's own K u + C w along its coarse path and
// passes on the sub-steps' a_c + K u + C w instead: the coarse node then
// moves as the sub-steps did but for Φ, where the line through a_c alone
// left it to its own stiffness and damping, and its displacement missed the
// sub-steps' by ~C H² Δw (the miss below). In the stage the stand-in is
// a_c = p + q s with q = −(C + γ K) ≥ 0, which needs γ ḡ q < 1; ḡ ≤ 1,
// so it is used up to γ q = 1/2 (H ~ 1 µs here), beyond which the line
// through a_c alone is.
bool MultirateIntegrator::cancels_own(double H, const std::vector<std::size_t>& fast) const {
  double gamma_max = 0.0;
  for (int i = 1; i < table_.stages; ++i) gamma_max = std::max(gamma_max, H * table_.at(i, i));
  bool cancel_own = true;
  for (const std::size_t j : fast) {
    const NodeCoupling& c = couplings_[j];
    cancel_own = cancel_own && gamma_max * -(c.damping + gamma_max * c.stiffness) <= 0.5;
  }
  return cancel_own;
}

// Φ for the next pass: the polynomial through this attempt's coarse stages
// (z_) and the fast neighbours' sub-steps in `fine`.
Forcing MultirateIntegrator::forcing_from(const Attempt& a, std::size_t q,
                                          const std::vector<SubstepResult>& fine) const {
  std::vector<std::array<double, 2>> phi(a.stage_tau.size());
  for (std::size_t i = 0; i < phi.size(); ++i) {
    std::array<double, 2> out{};
    for (const Coupling::Entry& e : a.coupling.slow[q])
      out[static_cast<std::size_t>(e.row)] +=
          e.coefficient * z_[i][static_cast<std::size_t>(e.column)];
    phi[i] = out;
  }
  Forcing f = Forcing::through(a.H, a.stage_tau, phi);
  for (const Coupling::FastEntry& e : a.coupling.fast[q])
    f.fine_terms.push_back({e.row, e.coefficient, &fine[e.other], e.component});
  // Grouped by source: Forcing::at interpolates each once.
  std::stable_sort(f.fine_terms.begin(), f.fine_terms.end(),
                   [](const auto& x, const auto& y) { return x.source < y.source; });
  return f;
}

// A retry's first Φ for its fast contacts `fast`: the polynomial through Φ
// along the stages this attempt solved (all of them).
std::vector<Forcing> MultirateIntegrator::forcing_through_stages(
    const std::vector<std::size_t>& fast, double H) const {
  std::vector<double> stage_tau(static_cast<std::size_t>(table_.stages));
  for (std::size_t i = 0; i < stage_tau.size(); ++i) stage_tau[i] = table_.c[i] * H;
  std::vector<Forcing> forcing(fast.size());
  std::vector<std::array<double, 2>> phi(stage_tau.size());
  for (std::size_t q = 0; q < fast.size(); ++q) {
    const NodeCoupling& c = couplings_[fast[q]];
    for (std::size_t i = 0; i < phi.size(); ++i) phi[i] = c.forcing(z_[i].data());
    forcing[q] = Forcing::through(H, stage_tau, phi);
  }
  return forcing;
}

// 2. The fast contacts' sub-steps under Φ, and each one's stand-in: the line
// with ∫a = A0 and ∫τ a = A1 over [0, H], so that the coarse node passes on
// the sub-steps' impulse and their displacement.
std::optional<MultirateIntegrator::Outcome> MultirateIntegrator::substep_fast(Attempt& a) {
  Step& st = a.st;
  const double H = a.H;
  auto& current = a.current();
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    const std::array<double, 4> x0{y_[ux], y_[ux + 1], y_[wx], y_[wx + 1]};
    const double h_try = substep_[j] > 0.0 ? substep_[j] : H / 16.0;
    try {
      current[q] = a.substeps.advance(j, couplings_[j], H, x0, contact_a_[j], a.forcing[q], h_try);
    } catch (const StageNotConverged& e) {
      ++stats_.convergence_failures;
      a.worst = wx;
      return Outcome{AttemptRecord::Verdict::shrink_substeps, e.what(), {}, {}};
    }
    counts_.substeps += current[q].substeps;
    counts_.substep_failures += current[q].rejected;
    const SubstepPoint& end = current[q].points.back();
    for (int k = 0; k < 2; ++k) {
      const double A0 = a.cancel_own ? current[q].own_impulse[k] : current[q].impulse[k];
      const double A1 = a.pass == 0
                            ? (a.cancel_own ? current[q].own_moment[k] : current[q].moment[k])
                            : H * A0 + a.coarse_part[q][k] - end.x[k];
      a.line_part[q][k] = H * A0 - A1;
      st.line0[q][k] = 4.0 * A0 / H - 6.0 * A1 / (H * H);
      st.line1[q][k] = 12.0 * A1 / (H * H * H) - 6.0 * A0 / (H * H);
    }
  }
  return std::nullopt;
}

// 3. The coarse ESDIRK stages of everything, the fast contacts' law replaced
// by their stand-ins. A stage refused for a slow contact's γλ turns that
// contact fast and retries the step at the same H, if enough are fast then.
std::optional<MultirateIntegrator::Outcome> MultirateIntegrator::coarse_stages(Attempt& a) {
  Step& st = a.st;
  const double H = a.H;
  const int s = table_.stages;
  auto f0 = st.f0;
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    const NodeCoupling& c = couplings_[j];
    for (int k = 0; k < 2; ++k) {
      const double own = a.cancel_own ? c.stiffness * y_[ux + k] + c.damping * y_[wx + k] : 0.0;
      f0[wx + k] += st.line0[q][k] - own - contact_a_[j][k];
    }
  }
  z_[0] = st.y0;
  f_[0] = f0;
  stages_.release_all();
  for (int i = 1; i < s; ++i) {
    for (std::size_t r = 0; r < n_; ++r) {
      double sum = 0.0;
      for (int l = 0; l < i; ++l) sum += table_.at(i, l) * f_[static_cast<std::size_t>(l)][r];
      b_[r] = st.y0[r] + H * sum;
    }
    const double tau = a.stage_tau[static_cast<std::size_t>(i)];
    const double gamma = H * table_.at(i, i);
    for (std::size_t q = 0; q < st.fast.size(); ++q) {
      // The stand-in: line − K u − C w with u = b_u + γ w at the stage.
      const std::size_t j = st.fast[q];
      const auto ux = u_of(system_, j);
      const NodeCoupling& c = couplings_[j];
      std::array<double, 2> p{};
      for (int k = 0; k < 2; ++k)
        p[k] =
            st.line0[q][k] + st.line1[q][k] * tau - (a.cancel_own ? c.stiffness * b_[ux + k] : 0.0);
      stages_.prescribe(j, p, a.cancel_own ? -(c.damping + gamma * c.stiffness) : 0.0);
    }
    auto& z = z_[static_cast<std::size_t>(i)];
    z = b_;
    try {
      ++stats_.rhs_implicit;
      stats_.newton_iterations +=
          stages_.solve(t_ + tau, gamma, z_[static_cast<std::size_t>(i - 1)], weights_, z);
    } catch (const StageNotConverged& e) {
      stages_.release_all();
      const auto refused = stages_.refused_sites();
      if (!refused.empty()) {  // those contacts turn fast
        for (const std::size_t j : refused) partition_.hold_fast(j);
        a.worst = w_of(system_, refused.front());
        auto fast =
            partition_.fast_contacts(H, y_, lattice_f_, contact_a_, step_ && !step_->fast.empty());
        if (!fast.empty())
          return Outcome{
              AttemptRecord::Verdict::retry_refused_stage, e.what(), std::move(fast), {}};
      }
      ++stats_.convergence_failures;
      return Outcome{AttemptRecord::Verdict::shrink_stage, e.what(), {}, {}};
    }
    auto& f = f_[static_cast<std::size_t>(i)];
    for (std::size_t r = 0; r < n_; ++r) f[r] = (z[r] - b_[r]) / gamma;
  }
  stages_.release_all();
  return std::nullopt;
}

// 4. Error control: the coarse estimate, weighted (error_); a slow contact
// whose own in-plane velocity error exceeds 1 turns fast and the step is
// retried at the same H, if enough are fast then; the RMS over every
// component but the fast contacts' in-plane u, w ≤ 1.
std::optional<MultirateIntegrator::Outcome> MultirateIntegrator::check_error(Attempt& a) {
  Step& st = a.st;
  const int s = table_.stages;
  for (std::size_t r = 0; r < n_; ++r) {
    double e = 0.0;
    for (int l = 0; l < s; ++l)
      e += (table_.b[static_cast<std::size_t>(l)] - table_.d[static_cast<std::size_t>(l)]) *
           f_[static_cast<std::size_t>(l)][r];
    error_[r] = a.H * e * weights_[r];
  }
  bool turned = false;
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    if (a.is_fast[j]) continue;
    const auto wx = w_of(system_, j);
    if (std::hypot(error_[wx], error_[wx + 1]) / std::sqrt(2.0) > 1.0) {
      partition_.hold_fast(j);
      turned = true;
    }
  }
  if (turned) {
    auto fast =
        partition_.fast_contacts(a.H, y_, lattice_f_, contact_a_, step_ && !step_->fast.empty());
    if (!fast.empty()) {
      if (options_.on_attempt) a.worst = largest(error_);
      auto forcing = forcing_through_stages(fast, a.H);
      return Outcome{
          AttemptRecord::Verdict::retry_turned_fast, {}, std::move(fast), std::move(forcing)};
    }
    // Too few to step apart: the step is single rate, and its contacts
    // are held to the coarse norm like dirk's. Held to 1 each, they made
    // a third of the attempts fail (15x15, theta 0.04: 14 083 of 42 546,
    // 69.5 s against 39.7 s).
  }
  for (const std::size_t j : st.fast) {  // their coarse u, w are not the answer
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    error_[ux] = error_[ux + 1] = error_[wx] = error_[wx + 1] = 0.0;
  }
  double sum = 0.0;
  for (std::size_t r = 0; r < n_; ++r) sum += error_[r] * error_[r];
  st.error = std::sqrt(sum / static_cast<double>(n_ - 4 * st.fast.size()));
  if (options_.on_attempt) a.worst = largest(error_);
  if (!(st.error <= 1.0))
    return Outcome{
        AttemptRecord::Verdict::shrink_error, "the coarse error estimate exceeded 1", {}, {}};
  return std::nullopt;
}

// 5. The hand-back. The coupling: the Φ the next pass would use against the
// one used, at the coarse stages and the contact's sub-step ends, times how
// long the contact's velocity remembers a change of force: H, or 1/λ where
// its own damping λ (law and lattice) is faster (a stuck contact takes up a
// change of force in its friction). The miss: the coarse node's end against
// the sub-steps' (which replaces it).
std::optional<MultirateIntegrator::Outcome> MultirateIntegrator::hand_back(Attempt& a) {
  Step& st = a.st;
  const double H = a.H;
  const int s = table_.stages;
  auto& current = a.current();
  double coupling = 0.0, miss = 0.0;
  std::int64_t worst_coupling = -1, worst_miss = -1;
  const auto& z_end = z_[static_cast<std::size_t>(s - 1)];
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    // The stand-in passes on the sub-steps' impulse and displacement, but the
    // coarse node moves under Φ along the coarse stages, the sub-steps under
    // the Φ of the last pass (and, where its own K and C are not cancelled,
    // under them along its own path). Held to the tolerance like a local
    // error: where C H ~ 1 the miss, unchecked, made a contact creeping past
    // its peak force oscillate and grow from step to step.
    const SubstepPoint& end = current[q].points.back();
    const NodeCoupling& c = couplings_[j];
    for (int k = 0; k < 2; ++k) {
      const double du = end.x[k] - z_end[ux + k];
      // What a neighbour felt wrong: its dashpot's impulse η δu and its
      // spring's ~ k δu H/2, in velocity, weighted as the node's. (Scaled
      // by the node's own C and K, the sum over its ~5 neighbours, the miss
      // sized 75 % of a 15×15 block slip's coarse steps.)
      const double m =
          (c.neighbour_damping + 0.5 * c.neighbour_stiffness * H) * std::abs(du) * weights_[wx + k];
      if (m > miss) worst_miss = wx + k;
      miss = std::max(miss, m);
      a.coarse_part[q][k] = z_end[ux + k] - a.line_part[q][k];
    }
    a.next_forcing[q] = forcing_from(a, q, current);
    double memory = 0.0;
    for (const SubstepPoint& p : current[q].points) {
      const double rate =
          system_.contact_set().site_damping_rate(j, {p.x[2], p.x[3]}) - couplings_[j].damping;
      memory = std::max(memory, rate > 0.0 ? std::min(H, 1.0 / rate) : H);
    }
    auto compare = [&](double tau) {
      const auto used = a.forcing[q].at(tau), next = a.next_forcing[q].at(tau);
      for (int k = 0; k < 2; ++k) {
        const double d = memory * std::abs(next[k] - used[k]) * weights_[wx + k];
        if (d > coupling) worst_coupling = wx + k;
        coupling = std::max(coupling, d);
      }
    };
    for (int i = 1; i < s; ++i) compare(a.stage_tau[static_cast<std::size_t>(i)]);
    for (const SubstepPoint& p : current[q].points) compare(p.tau);
  }
  a.coupling_error = coupling;
  a.miss = miss;
  if (coupling <= kCouplingTolerance && miss <= kCouplingTolerance) {
    if (miss > 1.0) {
      st.error = miss;
      a.worst = worst_miss;
      return Outcome{AttemptRecord::Verdict::shrink_miss,
                     "a stand-in's displacement missed its sub-steps' end",
                     {},
                     {}};
    }
    st.miss = miss;
    st.error = std::max(st.error, miss);
    st.fine = std::move(current);
    st.partition_work = partition_work(st, a.cancel_own);
    st.y1 = z_end;
    st.f1 = f_[static_cast<std::size_t>(s - 1)];
    return Outcome{AttemptRecord::Verdict::accepted, {}, {}, {}};
  }
  a.worst = worst_coupling;
  return std::nullopt;
}

// What the energy audit sees of the partition in the step `st` just solved:
// the lattice worked on each stand-in a = ℓ − K u − C w (ℓ alone where its
// own K and C are not cancelled) along the coarse stages z_, while the
// contact dissipated along its sub-steps.
double MultirateIntegrator::partition_work(const Step& st, bool cancel_own) const {
  const double m = system_.mass();
  double work = 0.0;
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    const NodeCoupling& c = couplings_[j];
    for (int l = 0; l < table_.stages; ++l) {
      const auto& z = z_[static_cast<std::size_t>(l)];
      const double tau = table_.c[static_cast<std::size_t>(l)] * st.H;
      const double weight = st.H * table_.b[static_cast<std::size_t>(l)];
      for (int k = 0; k < 2; ++k) {
        const double own = cancel_own ? c.stiffness * z[ux + k] + c.damping * z[wx + k] : 0.0;
        work += weight * m * (st.line0[q][k] + st.line1[q][k] * tau - own) * z[wx + k];
      }
    }
    work += st.fine[q].points.back().dissipated;
  }
  return work;
}

void MultirateIntegrator::report(const Attempt& a, const Outcome& o) const {
  if (!options_.on_attempt) return;
  AttemptRecord r;
  r.t = t_;
  r.h = a.H;
  r.fast_contacts = static_cast<long>(a.st.fast.size());
  r.coupling_pass = a.pass + 1;
  r.error = a.st.error;
  r.coupling = a.coupling_error;
  r.miss = a.miss;
  r.verdict = o.verdict;
  r.worst = a.worst;
  options_.on_attempt(r);
}

// 6. The step `trial_` holds is the solution from here on.
void MultirateIntegrator::accept() {
  Step& st = *trial_;
  // The slow contacts' a_c as their last stage had it.
  std::vector<char> is_fast(contact_a_.size(), 0);
  for (const std::size_t j : st.fast) is_fast[j] = 1;
  for (std::size_t j = 0; j < contact_a_.size(); ++j)
    if (!is_fast[j]) contact_a_[j] = stages_.contact_acceleration(j);
  y_ = st.y1;
  const auto diss = system_.quadrature_index(System::dissipated);
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    const SubstepPoint& end = st.fine[q].points.back();
    y_[ux] = end.x[0];
    y_[ux + 1] = end.x[1];
    y_[wx] = end.x[2];
    y_[wx + 1] = end.x[3];
    y_[diss] += end.dissipated;
    contact_a_[j] = st.fine[q].contact_acceleration;
    substep_[j] = st.fine[q].last_substep;
  }
  for (std::size_t j = 0; j < substep_.size(); ++j)
    if (!is_fast[j]) substep_[j] = 0.0;  // a contact turning fast again starts afresh
  t_ = st.t0 + st.H;
  if (t_stop_ - t_ < 1e-12 * std::abs(t_stop_)) t_ = t_stop_;
  begin_step_derivative();
  partition_.step_accepted();
  std::swap(step_, trial_);
  ++stats_.steps;
  counts_.fast_contact_steps += static_cast<long>(step_->fast.size());
  counts_.partition_work += step_->partition_work;
  stats_.last_step = st.H;
  if (!roots_.empty()) sample_speeds();
  record(step_->error);
}

void MultirateIntegrator::sample_speeds() {
  const Step& st = *step_;
  // Every later return lies in this step (advance): what came before it is settled.
  peaks_.settle(st.t0);
  std::vector<long> fast_index(contact_a_.size(), -1);
  for (std::size_t q = 0; q < st.fast.size(); ++q) fast_index[st.fast[q]] = static_cast<long>(q);
  for (std::size_t k = 0; k < roots_.size(); ++k) {
    const auto c = static_cast<std::size_t>(options_.watched_contacts[k]);  // = its site
    if (fast_index[c] < 0) {
      peaks_.sample(k, t_, system_.contact_set().contact_speed(c, y_));
      continue;
    }
    for (const SubstepPoint& p : st.fine[static_cast<std::size_t>(fast_index[c])].points)
      peaks_.sample(k, st.t0 + p.tau, std::hypot(p.x[2], p.x[3]));
  }
}

void MultirateIntegrator::record(double error) {
  if (!options_.on_step) return;
  // h λ over the slow contacts: the fast ones are held to it by their sub-steps.
  double rate = 0.0;
  std::vector<char> is_fast(contact_a_.size(), 0);
  for (const std::size_t j : step_->fast) is_fast[j] = 1;
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    if (is_fast[j]) continue;
    const auto wx = w_of(system_, j);
    rate = std::max(rate, system_.contact_set().site_weakening_rate(j, {y_[wx], y_[wx + 1]}));
  }
  StepRecord r{t_, step_->H, error, step_->H * rate};
  long substeps = 0;
  for (const auto& fine : step_->fine) substeps += fine.substeps;
  r.method_values = {static_cast<double>(step_->fast.size()), static_cast<double>(substeps),
                     step_->miss};
  options_.on_step(r);
}

void MultirateIntegrator::interpolate(double t, std::span<double> y) const {
  if (!step_ || t >= t_) {
    std::copy(y_.begin(), y_.end(), y.begin());
    return;
  }
  const Step& st = *step_;
  const double tau = t - st.t0, h = st.H;
  const auto w = hermite_weights(std::clamp(tau / h, 0.0, 1.0), h);
  for (std::size_t r = 0; r < n_; ++r)
    y[r] = w.a * st.y0[r] + w.b * st.f0[r] + w.c * st.y1[r] + w.d * st.f1[r];
  const auto diss = system_.quadrature_index(System::dissipated);
  for (std::size_t q = 0; q < st.fast.size(); ++q) {
    const std::size_t j = st.fast[q];
    const auto ux = u_of(system_, j), wx = w_of(system_, j);
    const auto x = st.fine[q].at(tau);
    y[ux] = x[0];
    y[ux + 1] = x[1];
    y[wx] = x[2];
    y[wx + 1] = x[3];
    y[diss] += st.fine[q].dissipated_at(tau);
  }
}

bool MultirateIntegrator::next_root(double t_from, double t_to, double& t_root) {
  if (roots_.empty() || !step_ || !(t_to > t_from)) return false;
  const Step& st = *step_;
  std::vector<long> fast_index(contact_a_.size(), -1);
  for (std::size_t q = 0; q < st.fast.size(); ++q) fast_index[st.fast[q]] = static_cast<long>(q);
  // Watched contact k's stick/slip root (the law's) at t in the step (patch = 1: contact
  // c is site c); its speed is a sample for peaks_.
  auto g = [&](std::size_t k, double t) {
    const auto c = static_cast<std::size_t>(options_.watched_contacts[k]);
    const double tau = t - st.t0;
    std::array<double, 2> s{};
    if (fast_index[c] >= 0) {
      const auto x = st.fine[static_cast<std::size_t>(fast_index[c])].at(tau);
      s = {x[2], x[3]};
    } else if (t >= t_) {
      const auto wx = w_of(system_, c);
      s = {y_[wx], y_[wx + 1]};
    } else {
      const auto w = hermite_weights(std::clamp(tau / st.H, 0.0, 1.0), st.H);
      const auto wx = static_cast<std::size_t>(w_of(system_, c));
      for (std::size_t axis = 0; axis < 2; ++axis)
        s[axis] = w.a * st.y0[wx + axis] + w.b * st.f0[wx + axis] + w.c * st.y1[wx + axis] +
                  w.d * st.f1[wx + axis];
    }
    ++stats_.root_evaluations;
    const double speed = std::hypot(s[0], s[1]);
    peaks_.sample(k, t, speed);
    return system_.contact_set().stick_slip_root(c, speed);
  };
  bool found = false;
  double best = t_to;
  std::vector<std::pair<std::size_t, int>> crossings;  // watched index, new side
  for (std::size_t k = 0; k < roots_.size(); ++k) {
    const auto c = static_cast<std::size_t>(options_.watched_contacts[k]);
    // Where to look: a fast contact's sub-step ends, a slow one's step end.
    std::vector<double> ends;
    if (fast_index[c] >= 0)
      for (const auto& p : st.fine[static_cast<std::size_t>(fast_index[c])].points) {
        const double t = st.t0 + p.tau;
        if (t > t_from && t < t_to) ends.push_back(t);
      }
    ends.push_back(t_to);
    double lo = t_from;
    for (const double hi : ends) {
      if (found && hi > best) break;
      const int side = g(k, hi) > 0.0 ? 1 : -1;
      if (side == sign_[k]) {
        lo = hi;
        continue;
      }
      // Bisect to the first time on the new side.
      double a = lo, b = hi;
      for (int it = 0; it < 80 && b - a > 1e-15 * std::abs(b); ++it) {
        const double mid = 0.5 * (a + b);
        ((g(k, mid) > 0.0 ? 1 : -1) == sign_[k] ? a : b) = mid;
      }
      if (!found || b < best) {
        crossings.clear();
        best = b;
      }
      if (b <= best) crossings.emplace_back(k, side);
      found = true;
      break;
    }
  }
  if (!found) return false;
  for (const auto& [k, side] : crossings) {
    roots_[k] = side;
    sign_[k] = side;
  }
  t_root = best;
  return true;
}

double MultirateIntegrator::advance(double t_out, std::span<double> y) {
  const double t = advance_to(t_out, y);
  peaks_.close(t);
  return t;
}

double MultirateIntegrator::advance_to(double t_out, std::span<double> y) {
  std::fill(roots_.begin(), roots_.end(), 0);
  for (;;) {
    if (step_ && t_reached_ < t_) {
      double t_root = 0.0;
      if (next_root(t_reached_, std::min(t_out, t_), t_root)) {
        t_reached_ = t_root;
        interpolate(t_root, y);
        return t_root;
      }
    }
    if (t_out <= t_) {
      t_reached_ = std::max(t_reached_, t_out);
      interpolate(t_out, y);
      return t_out;
    }
    t_reached_ = t_;
    if (options_.poll && ++steps_since_poll_ >= poll_steps_) {
      steps_since_poll_ = 0;
      if (options_.poll()) {
        std::copy(y_.begin(), y_.end(), y.begin());
        return t_;
      }
    }
    if (stats_.steps >= solver_.max_steps)
      throw IntegrationError(describe_out_of_steps(t_, stats_.steps, stats_.last_step));
    take_step();
  }
}

// Attempts at the next coarse step until one is accepted: a retry at the same
// H with more contacts fast, or a shorter step after a failed test. A step
// that failed here does not grow 5x again at once: after a stage that did not
// converge the regrown step failed again (docs/notes/performance-history.md).
void MultirateIntegrator::take_step() {
  const double exponent = -1.0 / (table_.embedded_order + 1);
  bool failed = false;
  std::optional<Outcome> retry;
  for (;;) {
    const double H = std::min(h_, t_stop_ - t_);
    ++stats_.step_attempts;
    Outcome o = attempt(H, std::move(retry));
    retry.reset();
    if (o.verdict == AttemptRecord::Verdict::accepted) {
      const double e = std::max(trial_->error, 1e-10);
      double growth = std::clamp(0.9 * std::pow(e, exponent), 0.2, failed ? 1.0 : 5.0);
      // Growth by less than kKeepStep keeps the step, so the lattice's
      // factorization at this γ serves the next one too.
      if (growth >= 1.0 && growth <= kKeepStep) growth = 1.0;
      // A step cut short to land on t_stop does not shrink the next.
      h_ = H < h_ ? std::max(h_, H * growth) : H * growth;
      accept();
      return;
    }
    if (o.verdict == AttemptRecord::Verdict::retry_turned_fast ||
        o.verdict == AttemptRecord::Verdict::retry_refused_stage) {
      retry = std::move(o);  // the same H with more contacts fast
      continue;
    }
    ++stats_.error_test_failures;
    failed = true;
    const double e = trial_->error;
    h_ = H *
         (std::isfinite(e) && e > 1.0 ? std::clamp(0.9 * std::pow(e, exponent), 0.1, 0.9) : 0.25);
    last_failure_ = std::move(o);
    if (!(h_ > 1e-18)) throw IntegrationError(failure(H));
  }
}

// The coarse step fell below 1e-18 s: where, what the last attempt came to
// and why, and (where its error was estimated) the largest weighted local
// errors, as the SUNDIALS-backed methods' failures name them.
std::string MultirateIntegrator::failure(double H) const {
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "multirate: the coarse step fell below 1e-18 s at t = %.9g s (last attempt "
                "%.3g s, %zu contacts fast): ",
                t_, H, trial_->fast.size());
  std::string msg = buf;
  msg += AttemptRecord::kVerdictNames[static_cast<std::size_t>(last_failure_.verdict)];
  if (!last_failure_.reason.empty()) msg += " (" + last_failure_.reason + ")";
  if (!std::isfinite(trial_->error)) return msg;
  return msg + largest_errors(system_, error_);
}

SolverStats MultirateIntegrator::stats() const {
  SolverStats s = stats_;
  s.linear_setups = stages_.lattice().factorizations();
  s.jacobian_evaluations = stages_.contact_factorizations();
  s.krylov_iterations = stages_.krylov_iterations();
  s.method = {{"substeps", counts_.substeps},
              {"substep_failures", counts_.substep_failures},
              {"fast_contact_steps", counts_.fast_contact_steps},
              {"coupling_iterations", counts_.coupling_iterations},
              {"partition_work", counts_.partition_work}};
  return s;
}

nlohmann::json MultirateIntegrator::description() const {
  // Tolerances and the rest of summary.json's solver object: describe_solver.
  return {{"method", "multirate"},
          {"integrator", integrator_text(Method::multirate, solver_.linear_solver)},
          {"order", table_.order},
          {"stages", table_.stages},
          {"coupling_tolerance", kCouplingTolerance},
          {"min_fast_contacts", solver_.multirate_min_fast},
          {"coupling_iterations", kCouplingIterations}};
}

}  // namespace stickslip
