#include "stickslip/integrate/multirate_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>

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
  int coupling_iterations = 0;
  // The stand-ins' work on their coarse paths plus the contacts' dissipation
  // on their sub-steps [J] (SolverStats::partition_work).
  double partition_work = 0.0;
};

namespace {

// The state index of site j's u_x and w_x.
std::int64_t u_of(const System& s, std::size_t j) {
  return s.u_index(s.sites()[j].node, 0);
}
std::int64_t w_of(const System& s, std::size_t j) {
  return s.w_index(s.sites()[j].node, 0);
}

// MR_DEBUG=1: one line per coarse attempt on stderr (for the measurements in
// docs/PERFORMANCE.md; off in any normal run).
bool debug() {
  static const bool on = std::getenv("MR_DEBUG") != nullptr;
  return on;
}

// Per site: 1 where at most `neighbours` of the eight sites around it
// (periodic in x and y) hold a contact.
std::vector<char> lone_sites(const System& s, int neighbours) {
  const int nx = s.nx(), ny = s.ny();
  std::vector<char> occupied(static_cast<std::size_t>(nx) * ny, 0);
  for (const FrictionSite& site : s.sites())
    occupied[static_cast<std::size_t>(site.ix + nx * site.iy)] = 1;
  std::vector<char> lone(s.sites().size());
  for (std::size_t j = 0; j < lone.size(); ++j) {
    const FrictionSite& site = s.sites()[j];
    int count = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int x = (site.ix + dx + nx) % nx, y = (site.iy + dy + ny) % ny;
        if ((x != site.ix || y != site.iy) && occupied[static_cast<std::size_t>(x + nx * y)])
          ++count;
      }
    lone[j] = count <= neighbours;
  }
  return lone;
}

}  // namespace

std::vector<long> MultirateIntegrator::contact_weights(const System& system, long min_fast) {
  const std::vector<char> lone = lone_sites(system, kLoneNeighbours);
  const auto lone_count = std::count(lone.begin(), lone.end(), char{1});
  const auto others = static_cast<long>(lone.size()) - lone_count;
  const bool one_goes_apart = 2 * lone_count >= static_cast<long>(lone.size()) &&
                              kLoneShare * lone_count + others >= min_fast;
  std::vector<long> weight(lone.size());
  for (std::size_t j = 0; j < lone.size(); ++j)
    weight[j] = lone[j] ? (one_goes_apart ? min_fast : kLoneShare) : 1;
  return weight;
}

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
      // (docs/PERFORMANCE.md, "Multirate at 60x60").
      stages_(system, LatticeStageSolver::kMaxGammaLambda),
      n_(y0.size()),
      t_stop_(t_stop),
      poll_steps_(poll_steps(Method::multirate, solver.linear_solver)),
      t_(t0),
      y_(y0.begin(), y0.end()),
      lattice_f_(n_),
      contact_a_(system.sites().size()),
      h_(0.0),
      substep_(system.sites().size(), 0.0),
      forced_fast_(system.sites().size(), 0),
      weight_(contact_weights(system, solver.multirate_min_fast)),
      t_reached_(t0),
      b_(n_),
      weights_(n_),
      error_(n_),
      f_(static_cast<std::size_t>(table_.stages), std::vector<double>(n_)),
      z_(static_cast<std::size_t>(table_.stages), std::vector<double>(n_)) {
  if (system.patch() != 1)
    throw std::invalid_argument("method = \"multirate\" steps single-site contacts (patch = 1)");
  // At the start a_c is the law's: the one time it is evaluated at a state
  // rather than taken from a stage (as ARKStep's first f for dirk).
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    const auto wx = w_of(system_, j);
    contact_a_[j] = system_.site_acceleration(j, {y_[wx], y_[wx + 1]});
  }
  begin_step_derivative();
  roots_.assign(options_.watched_contacts.size(), 0);
  peaks_ = SpeedPeaks(roots_.size());
  sign_.resize(roots_.size());
  std::vector<double> g(roots_.size());
  system_.stick_slip_roots(y_, options_.watched_contacts, g);
  for (std::size_t k = 0; k < g.size(); ++k) sign_[k] = g[k] > 0.0 ? 1 : -1;
  // The first step: small against any time scale of the model (the contacts'
  // own ~1e-9 s near their peak); the controller grows it 5× a step.
  h_ = std::min(1e-10, 0.5 * (t_stop - t0));
}

MultirateIntegrator::~MultirateIntegrator() = default;

// The lattice's part of f at (t_, y_): u' = w, a_L, and the quadratures' rates
// without the contacts' dissipation (added per site, with the a_c the step uses).
void MultirateIntegrator::begin_step_derivative() {
  system_.rhs_explicit(t_, y_, lattice_f_);
  lattice_f_[system_.quadrature_index(System::dissipated)] = system_.lattice_dissipation(y_);
  ++stats_.rhs_explicit;
}

// The partition rule, in one place. A contact is fast for a coarse step of
// size H when that step cannot follow it: it slips (|s| > κ v*, MODEL.md §9),
// or its speed changes by more than a factor e over H (|s·a|/|s|² H > 1, a
// the node's whole acceleration at the step's start: an onset, an arrest),
// or an attempt at this step, or at one of the last kFastHold steps, found
// its own error above 1 or refused its stage for γλ > 1 (forced_fast_).
// Fewer than multirate_min_fast such contacts and the step is single rate:
// on 15x15x10 (theta05, 112 contacts) the whole run took 96.0 s with every
// fast contact stepped apart, 79.0 / 77.9 / 70.0 / 60.9 / 57.2 s from 4 / 8 /
// 16 / 32 / 64 on, and dirk 70.3 s (docs/PERFORMANCE.md).
std::vector<std::size_t> MultirateIntegrator::fast_contacts(double H) const {
  std::vector<std::size_t> fast;
  for (std::size_t j = 0; j < contact_a_.size(); ++j) {
    const auto wx = w_of(system_, j);
    const double sx = y_[wx], sy = y_[wx + 1];
    const double speed2 = sx * sx + sy * sy;
    bool is_fast = forced_fast_[j] > 0 || system_.slipping(j, y_);
    if (!is_fast && speed2 > 0.0) {
      const double ax = lattice_f_[wx] + contact_a_[j][0];
      const double ay = lattice_f_[wx + 1] + contact_a_[j][1];
      is_fast = std::abs(sx * ax + sy * ay) / speed2 * H > 1.0;
    }
    if (is_fast) fast.push_back(j);
  }
  // Once apart, a block slip's tail stays apart down to kStayApart times
  // fewer: its arrests, each of which collapses a single-rate step, come
  // after the slip proper (the loading's small clusters still step single
  // rate, where stepping them apart cost more).
  const bool apart = step_ && !step_->fast.empty();
  const long fewest = apart ? std::max<long>(1, solver_.multirate_min_fast / kStayApart)
                            : solver_.multirate_min_fast;
  // A lone contact (at most one other contact among the eight sites around
  // its own) counts more (contact_weights): it turns few slow neighbours
  // fast under its slip, so it is cheap to step apart, while lone slips each
  // collapsed the single-rate step (60x60x10 at θ = 0.04).
  long count = 0;
  for (const std::size_t j : fast) count += weight_[j];
  if (count < fewest) fast.clear();
  return fast;
}

MultirateIntegrator::Attempt MultirateIntegrator::attempt(double H) {
  const int s = table_.stages;
  const double m = system_.mass();
  const std::size_t n3 = static_cast<std::size_t>(3 * system_.num_nodes());
  if (!trial_) trial_ = std::make_unique<Step>();
  Step& st = *trial_;
  st.t0 = t_;
  st.H = H;
  st.y0 = y_;
  st.error = std::numeric_limits<double>::quiet_NaN();
  st.miss = 0.0;
  st.fast = fast_contacts(H);
  const std::size_t nf = st.fast.size();
  st.line0.assign(nf, {});
  st.line1.assign(nf, {});
  std::vector<char> is_fast(contact_a_.size(), 0);
  for (const std::size_t j : st.fast) is_fast[j] = 1;

  // f at the step's start: the lattice's part, each site's a_c, and the slow
  // contacts' dissipation (the fast ones' is their sub-steps').
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

  // Φ of each fast contact splits into what the coarse level gives (slow
  // components: a polynomial through its stages) and its fast neighbours'
  // in-plane motion, read off their sub-steps: a fast neighbour's coarse
  // stand-in has its impulse, not its timing.
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
  std::vector<std::vector<Entry>> slow_entries(nf);
  std::vector<std::vector<FastEntry>> fast_entries(nf);
  {
    // Each bottom node's fast contact, if any (sites are bottom nodes).
    const std::int64_t layer = std::int64_t{system_.nx()} * system_.ny();
    std::vector<long> fast_at(static_cast<std::size_t>(layer), -1);
    for (std::size_t q = 0; q < nf; ++q)
      fast_at[static_cast<std::size_t>(system_.sites()[st.fast[q]].node)] = static_cast<long>(q);
    const auto N3 = static_cast<std::int64_t>(n3);
    for (std::size_t q = 0; q < nf; ++q) {
      const NodeCoupling& c = couplings_[st.fast[q]];
      for (int k = 0; k < 2; ++k)
        for (std::size_t e = 0; e < c.column[k].size(); ++e) {
          const std::int64_t col = c.column[k][e];
          const bool velocity = col >= N3;
          const std::int64_t index = velocity ? col - N3 : col;  // 3 node + axis
          const std::int64_t node = index / 3;
          const int axis = static_cast<int>(index % 3);
          const long other = col < 2 * N3 && axis < 2 && node < layer
                                 ? fast_at[static_cast<std::size_t>(node)]
                                 : -1;
          if (other >= 0)
            fast_entries[q].push_back(
                {k, c.value[k][e], static_cast<std::size_t>(other), (velocity ? 2 : 0) + axis});
          else
            slow_entries[q].push_back({k, c.value[k][e], col});
        }
    }
  }
  auto slow_forcing = [&](std::size_t q, const std::vector<double>& y) {
    std::array<double, 2> out{};
    for (const Entry& e : slow_entries[q])
      out[static_cast<std::size_t>(e.row)] += e.coefficient * y[static_cast<std::size_t>(e.column)];
    return out;
  };
  // Φ for the next iteration: the polynomial through this coarse step's
  // stages and the fast neighbours' sub-steps in `fine`.
  std::vector<double> stage_tau(static_cast<std::size_t>(s));
  for (std::size_t i = 0; i < stage_tau.size(); ++i) stage_tau[i] = table_.c[i] * H;
  auto forcing_from = [&](std::size_t q, const std::vector<SubstepResult>& fine) {
    std::vector<std::array<double, 2>> phi(stage_tau.size());
    for (std::size_t i = 0; i < phi.size(); ++i) phi[i] = slow_forcing(q, z_[i]);
    Forcing f = Forcing::through(H, stage_tau, phi);
    for (const FastEntry& e : fast_entries[q])
      f.fine_terms.push_back({e.row, e.coefficient, &fine[e.other], e.component});
    // Grouped by source: Forcing::at interpolates each once.
    std::stable_sort(f.fine_terms.begin(), f.fine_terms.end(),
                     [](const auto& a, const auto& b) { return a.source < b.source; });
    return f;
  };

  ContactSubsteps substeps(system_, table_, solver_.rtol,
                           {atol_[0], atol_[1], atol_[n3], atol_[n3 + 1]});
  // Two sets of sub-steps: the last iteration's, which this iteration's Φ
  // reads, and this iteration's.
  std::array<std::vector<SubstepResult>, 2> fine{std::vector<SubstepResult>(nf),
                                                 std::vector<SubstepResult>(nf)};
  std::vector<Forcing> forcing(nf), next_forcing(nf);
  // The coarse node's end displacement is what the coarse level gives it
  // (u0 + w0 H, Φ along the stages, and, where its own K and C are not
  // cancelled, those along its path) plus its line's H A0 − A1. The first
  // line takes A1 from the sub-steps; the coarse level's part then differs
  // from theirs (they moved under the last iteration's Φ), and the coarse
  // node misses their end by δu. Each later line sets A1 so that the coarse
  // level's part of the last iteration (`coarse_part`) plus the line lands
  // on these sub-steps' end. A stuck contact takes a change of Φ up in its
  // friction: its sub-steps' end hardly moves, but their moments do, so a
  // line shifted by the last miss alone counted that change twice, came back
  // with the miss's sign flipped, and the miss then set the coarse step
  // (60x60x10 at θ = 0.04: ~8e-8 s, docs/PERFORMANCE.md).
  std::vector<std::array<double, 2>> coarse_part(nf, {0.0, 0.0}), line_part(nf, {0.0, 0.0});
  // The stand-in cancels the node's own K u + C w along its coarse path and
  // passes on the sub-steps' a_c + K u + C w instead: the coarse node then
  // moves as the sub-steps did but for Φ, where the line through a_c alone
  // left it to its own stiffness and damping, and its displacement missed the
  // sub-steps' by ~C H² Δw (the miss below). In the stage the stand-in is
  // a_c = p + q s with q = −(C + γ K) ≥ 0, which needs γ ḡ q < 1; ḡ ≤ 1,
  // so it is used up to γ q = 1/2 (H ~ 1 µs here), beyond which the line
  // through a_c alone is.
  double gamma_max = 0.0;
  for (int i = 1; i < s; ++i) gamma_max = std::max(gamma_max, H * table_.at(i, i));
  bool cancel_own = true;
  for (const std::size_t j : st.fast) {
    const NodeCoupling& c = couplings_[j];
    cancel_own = cancel_own && gamma_max * -(c.damping + gamma_max * c.stiffness) <= 0.5;
  }
  // The first Φ: where an attempt at this same step has just solved every
  // stage (a retry after a slow contact turned fast), the polynomial through
  // Φ along those stages; otherwise its Taylor line at the step's start.
  // (A retry comes at once, at the same H: advance_to.)
  const bool stages_known = retry_stages_known_;
  retry_stages_known_ = false;
  std::vector<std::array<double, 2>> phi(stage_tau.size());
  for (std::size_t q = 0; q < nf; ++q) {
    const NodeCoupling& c = couplings_[st.fast[q]];
    if (stages_known) {
      for (std::size_t i = 0; i < phi.size(); ++i) phi[i] = c.forcing(z_[i].data());
      forcing[q] = Forcing::through(H, stage_tau, phi);
    } else {
      forcing[q] = Forcing::taylor(H, c.forcing(st.y0.data()), c.forcing(st.f0.data()));
    }
  }
  for (int iteration = 0; iteration < kCouplingIterations; ++iteration) {
    st.coupling_iterations = iteration + 1;
    auto& current = fine[static_cast<std::size_t>(iteration % 2)];
    // 2. The fast contacts' sub-steps under Φ.
    for (std::size_t q = 0; q < nf; ++q) {
      const std::size_t j = st.fast[q];
      const auto ux = u_of(system_, j), wx = w_of(system_, j);
      const std::array<double, 4> x0{y_[ux], y_[ux + 1], y_[wx], y_[wx + 1]};
      const double h_try = substep_[j] > 0.0 ? substep_[j] : H / 16.0;
      try {
        current[q] = substeps.advance(j, couplings_[j], H, x0, contact_a_[j], forcing[q], h_try);
      } catch (const StageNotConverged&) {
        if (debug()) std::fprintf(stderr, "t=%.9e H=%.3e fine_fail\n", t_, H);
        ++stats_.convergence_failures;
        return Attempt::shrink;
      }
      stats_.substeps += current[q].substeps;
      stats_.substep_failures += current[q].rejected;
      // The line with ∫a = A0 and ∫τ a = A1 over [0, H]: the coarse node
      // then passes on the sub-steps' impulse and their displacement.
      const SubstepPoint& end = current[q].points.back();
      for (int k = 0; k < 2; ++k) {
        const double A0 = cancel_own ? current[q].own_impulse[k] : current[q].impulse[k];
        const double A1 = iteration == 0
                              ? (cancel_own ? current[q].own_moment[k] : current[q].moment[k])
                              : H * A0 + coarse_part[q][k] - end.x[k];
        line_part[q][k] = H * A0 - A1;
        st.line0[q][k] = 4.0 * A0 / H - 6.0 * A1 / (H * H);
        st.line1[q][k] = 12.0 * A1 / (H * H * H) - 6.0 * A0 / (H * H);
      }
    }
    // 3. The coarse step, the fast contacts' law replaced by their stand-ins.
    auto f0 = st.f0;
    for (std::size_t q = 0; q < nf; ++q) {
      const std::size_t j = st.fast[q];
      const auto ux = u_of(system_, j), wx = w_of(system_, j);
      const NodeCoupling& c = couplings_[j];
      for (int k = 0; k < 2; ++k) {
        const double own = cancel_own ? c.stiffness * y_[ux + k] + c.damping * y_[wx + k] : 0.0;
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
      const double tau = stage_tau[static_cast<std::size_t>(i)];
      const double gamma = H * table_.at(i, i);
      for (std::size_t q = 0; q < nf; ++q) {
        // The stand-in: line − K u − C w with u = b_u + γ w at the stage.
        const std::size_t j = st.fast[q];
        const auto ux = u_of(system_, j);
        const NodeCoupling& c = couplings_[j];
        std::array<double, 2> p{};
        for (int k = 0; k < 2; ++k)
          p[k] =
              st.line0[q][k] + st.line1[q][k] * tau - (cancel_own ? c.stiffness * b_[ux + k] : 0.0);
        stages_.prescribe(j, p, cancel_own ? -(c.damping + gamma * c.stiffness) : 0.0);
      }
      auto& z = z_[static_cast<std::size_t>(i)];
      z = b_;
      try {
        ++stats_.rhs_implicit;
        stats_.newton_iterations +=
            stages_.solve(t_ + tau, gamma, z_[static_cast<std::size_t>(i - 1)], weights_, z);
      } catch (const StageNotConverged&) {
        stages_.release_all();
        if (debug())
          std::fprintf(stderr, "t=%.9e H=%.3e fast=%zu stage_fail refused=%zu\n", t_, H, nf,
                       stages_.refused_sites().size());
        if (!stages_.refused_sites().empty()) {  // those contacts turn fast
          for (const std::size_t j : stages_.refused_sites()) forced_fast_[j] = kFastHold;
          if (!fast_contacts(H).empty()) return Attempt::retry;
        }
        ++stats_.convergence_failures;
        return Attempt::shrink;
      }
      auto& f = f_[static_cast<std::size_t>(i)];
      for (std::size_t r = 0; r < n_; ++r) f[r] = (z[r] - b_[r]) / gamma;
    }
    stages_.release_all();
    // 5. Error control.
    for (std::size_t r = 0; r < n_; ++r) {
      double e = 0.0;
      for (int l = 0; l < s; ++l)
        e += (table_.b[static_cast<std::size_t>(l)] - table_.d[static_cast<std::size_t>(l)]) *
             f_[static_cast<std::size_t>(l)][r];
      error_[r] = H * e * weights_[r];
    }
    bool turned = false;
    for (std::size_t j = 0; j < contact_a_.size(); ++j) {
      if (is_fast[j]) continue;
      const auto wx = w_of(system_, j);
      if (std::hypot(error_[wx], error_[wx + 1]) / std::sqrt(2.0) > 1.0) {
        forced_fast_[j] = kFastHold;
        turned = true;
      }
    }
    if (turned) {
      if (debug()) std::fprintf(stderr, "t=%.9e H=%.3e fast=%zu turned\n", t_, H, nf);
      if (!fast_contacts(H).empty()) {
        retry_stages_known_ = true;
        return Attempt::retry;
      }
      // Too few to step apart: the step is single rate, and its contacts
      // are held to the coarse norm like dirk's. Held to 1 each, they made
      // a third of the attempts fail (15x15, theta 0.04: 14 083 of 42 546,
      // 69.5 s against 39.7 s).
    }
    for (std::size_t q = 0; q < nf; ++q) {  // their coarse u, w are not the answer
      const auto ux = u_of(system_, st.fast[q]), wx = w_of(system_, st.fast[q]);
      error_[ux] = error_[ux + 1] = error_[wx] = error_[wx + 1] = 0.0;
    }
    double sum = 0.0;
    for (std::size_t r = 0; r < n_; ++r) sum += error_[r] * error_[r];
    st.error = std::sqrt(sum / static_cast<double>(n_ - 4 * nf));
    if (!(st.error <= 1.0)) {
      if (debug()) {
        std::size_t worst = 0;
        for (std::size_t r = 0; r < n_; ++r)
          if (std::abs(error_[r]) > std::abs(error_[worst])) worst = r;
        std::fprintf(stderr, "t=%.9e H=%.3e fast=%zu it=%d err=%.3g REJECT worst %s %.3g\n", t_, H,
                     nf, iteration, st.error,
                     system_.describe_component(static_cast<std::int64_t>(worst)).c_str(),
                     error_[worst]);
      }
      return Attempt::shrink;
    }
    // 4. The coupling: the Φ the next iteration would use against the one
    // used, at the coarse stages and the contact's sub-step ends, times how
    // long the contact's velocity remembers a change of force: H, or 1/λ
    // where its own damping λ (law and lattice) is faster (a stuck contact
    // takes up a change of force in its friction).
    double coupling = 0.0, miss = 0.0;
    const auto& z_end = z_[static_cast<std::size_t>(s - 1)];
    for (std::size_t q = 0; q < nf; ++q) {
      const std::size_t j = st.fast[q];
      const auto ux = u_of(system_, j), wx = w_of(system_, j);
      // The coarse node's end against the sub-steps' (which replaces it): the
      // stand-in passes on their impulse and displacement, but the coarse node
      // moves under Φ along the coarse stages, the sub-steps under the Φ of
      // the last iteration (and, where its own K and C are not cancelled,
      // under them along its own path). Held to the tolerance like a local
      // error: where C H ~ 1 the miss, unchecked, made a contact creeping
      // past its peak force oscillate and grow from step to step.
      const SubstepPoint& end = current[q].points.back();
      const NodeCoupling& c = couplings_[j];
      for (int k = 0; k < 2; ++k) {
        const double du = end.x[k] - z_end[ux + k];
        // What a neighbour felt wrong: its dashpot's impulse η δu and its
        // spring's ~ k δu H/2, in velocity, weighted as the node's. (Scaled
        // by the node's own C and K, the sum over its ~5 neighbours, the miss
        // sized 75 % of a 15×15 block slip's coarse steps.)
        miss = std::max(miss, (c.neighbour_damping + 0.5 * c.neighbour_stiffness * H) *
                                  std::abs(du) * weights_[wx + k]);
        coarse_part[q][k] = z_end[ux + k] - line_part[q][k];
      }
      next_forcing[q] = forcing_from(q, current);
      double memory = 0.0;
      for (const SubstepPoint& p : current[q].points) {
        const double rate = system_.site_damping_rate(j, {p.x[2], p.x[3]}) - couplings_[j].damping;
        memory = std::max(memory, rate > 0.0 ? std::min(H, 1.0 / rate) : H);
      }
      auto compare = [&](double tau) {
        const auto used = forcing[q].at(tau), next = next_forcing[q].at(tau);
        for (int k = 0; k < 2; ++k)
          coupling = std::max(coupling, memory * std::abs(next[k] - used[k]) * weights_[wx + k]);
      };
      for (int i = 1; i < s; ++i) compare(stage_tau[static_cast<std::size_t>(i)]);
      for (const SubstepPoint& p : current[q].points) compare(p.tau);
    }
    if (debug())
      std::fprintf(stderr, "t=%.9e H=%.3e fast=%zu it=%d err=%.3g coupling=%.3g miss=%.3g\n", t_, H,
                   nf, iteration, st.error, coupling, miss);
    if (coupling <= kCouplingTolerance && miss <= kCouplingTolerance) {
      if (miss > 1.0) {
        st.error = miss;
        return Attempt::shrink;
      }
      st.miss = miss;
      st.error = std::max(st.error, miss);
      st.fine = std::move(current);
      st.partition_work = partition_work(st, cancel_own);
      return Attempt::accepted;
    }
    ++stats_.coupling_iterations;
    std::swap(forcing, next_forcing);  // reads `current`, which the next iteration keeps
  }
  return Attempt::shrink;
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

void MultirateIntegrator::accept(double H) {
  const int s = table_.stages;
  Step& st = *trial_;
  const auto& z_end = z_[static_cast<std::size_t>(s - 1)];
  st.y1 = z_end;
  st.f1 = f_[static_cast<std::size_t>(s - 1)];
  // The slow contacts' a_c as their last stage had it.
  std::vector<char> is_fast(contact_a_.size(), 0);
  for (const std::size_t j : st.fast) is_fast[j] = 1;
  for (std::size_t j = 0; j < contact_a_.size(); ++j)
    if (!is_fast[j]) contact_a_[j] = stages_.contact_acceleration(j);
  y_ = z_end;
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
  t_ = st.t0 + H;
  if (t_stop_ - t_ < 1e-12 * std::abs(t_stop_)) t_ = t_stop_;
  begin_step_derivative();
  for (auto& hold : forced_fast_) hold = hold > 0 ? hold - 1 : 0;
  std::swap(step_, trial_);
  ++stats_.steps;
  stats_.fast_contact_steps += static_cast<long>(step_->fast.size());
  stats_.partition_work += step_->partition_work;
  stats_.last_step = H;
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
      peaks_.sample(k, t_, system_.contact_speed(c, y_));
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
    rate = std::max(rate, system_.site_weakening_rate(j, {y_[wx], y_[wx + 1]}));
  }
  StepRecord r{t_, step_->H, error, step_->H * rate};
  r.fast_contacts = static_cast<long>(step_->fast.size());
  long substeps = 0;
  for (const auto& fine : step_->fine) substeps += fine.substeps;
  r.substeps = substeps;
  r.miss = step_->miss;
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
  const double kappa = system_.slip_threshold();
  std::vector<long> fast_index(contact_a_.size(), -1);
  for (std::size_t q = 0; q < st.fast.size(); ++q) fast_index[st.fast[q]] = static_cast<long>(q);
  // Watched contact k's g = |s| − κ v* at t in the step (patch = 1: contact
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
    return speed - kappa * system_.contacts()[c].v_star;
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
    const double exponent = -1.0 / (table_.embedded_order + 1);
    // A step that failed here does not grow 5x again at once: after a stage
    // that did not converge the regrown step failed again (docs/PERFORMANCE.md).
    bool failed = false;
    for (;;) {
      const double H = std::min(h_, t_stop_ - t_);
      ++stats_.step_attempts;
      const Attempt a = attempt(H);
      if (a == Attempt::accepted) {
        const double e = std::max(trial_->error, 1e-10);
        double growth = std::clamp(0.9 * std::pow(e, exponent), 0.2, failed ? 1.0 : 5.0);
        // Growth by less than kKeepStep keeps the step, so the lattice's
        // factorization at this γ serves the next one too.
        if (growth >= 1.0 && growth <= kKeepStep) growth = 1.0;
        // A step cut short to land on t_stop does not shrink the next.
        h_ = H < h_ ? std::max(h_, H * growth) : H * growth;
        accept(H);
        break;
      }
      if (a == Attempt::retry) continue;  // the same H with more contacts fast
      ++stats_.error_test_failures;
      failed = true;
      const double e = trial_->error;
      h_ = H *
           (std::isfinite(e) && e > 1.0 ? std::clamp(0.9 * std::pow(e, exponent), 0.1, 0.9) : 0.25);
      if (!(h_ > 1e-18))
        throw IntegrationError(
            "multirate: the coarse step fell below 1e-18 s at t = " + std::to_string(t_) + " s");
    }
  }
}

SolverStats MultirateIntegrator::stats() const {
  SolverStats s = stats_;
  s.linear_setups = stages_.lattice().factorizations();
  s.jacobian_evaluations = stages_.contact_factorizations();
  s.krylov_iterations = stages_.krylov_iterations();
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
