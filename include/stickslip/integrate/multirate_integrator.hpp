#pragma once
// method = "multirate": contacts on their own clocks.
//
// In a block slip every contact's start and stop used to collapse the one
// global step (docs/PERFORMANCE.md, "Multirate", "Why"):
// a re-sticking contact's speed halves at every step for ~15 ns, and the
// whole lattice was stepped at 1e-11 s through it. Here a coarse step of
// dirk's ESDIRK advances the lattice and the slow contacts, with the exact
// FFT stage solve (LatticeStageSolver); each fast contact advances on
// sub-steps of its own (ContactSubsteps) with the rest of the lattice's force
// on it given by the coarse level, and hands its impulse back to the coarse
// level. One coarse step:
//
//  1. Partition (fast_contacts): which contacts the coarse step cannot resolve.
//     Fewer than [solver] multirate_min_fast of them and there are none: the
//     step is single rate, as dirk's (a single slip costs less so: its stand-in
//     pinned the coarse step to its miss, with three coupling passes a step).
//     After a step with contacts apart the bar is kStayApart times lower: a
//     block slip's tail of arrests stays apart. A lone contact (at most one
//     other around it) counts kLoneShare: many lone slips at once go apart;
//     where most contacts are lone, one alone does (contact_weights).
//  2. Each fast contact's sub-steps over [t, t + H] under Φ(t), the rest of
//     the lattice's acceleration on its node: first Φ's Taylor line at t (in
//     a retry at the same H, the polynomial through Φ along the stages of the
//     attempt it repeats), then the polynomial through the coarse stages, a
//     fast neighbour's part read off that neighbour's sub-steps.
//  3. The coarse ESDIRK step of everything, each fast contact's law replaced
//     by a stand-in: the line ℓ(τ) = p0 + p1 τ with the same ∫ and ∫τ as
//     its sub-steps' a_c + K u + C w (its node's own acceleration, all but
//     Φ; from the second iteration ∫τ such that the coarse level's part of
//     the node's displacement in the last iteration plus the line's lands on
//     the sub-steps' end), less K u + C w along the coarse path. The coarse
//     node then moves under Φ and ℓ alone, as the sub-steps did under Φ: its
//     neighbours see its impulse and displacement. (Up to γ(−C − γK) = 1/2,
//     H ~ 1 µs; beyond, the line through a_c alone.)
//  4. If Φ along the coarse stages differs from the Φ the sub-steps used by
//     more than the tolerance can absorb (H |ΔΦ| weighted, or |ΔΦ|/λ where
//     the contact's own damping λ is faster), or the stand-in's displacement
//     misses the sub-steps' (what the neighbours then felt wrong, weighted),
//     2–3 again (at most kCouplingIterations times).
//  5. Error control: the coarse embedded estimate over every component but
//     the fast contacts' in-plane u and w (weighted RMS ≤ 1); each slow
//     contact's own in-plane velocity error ≤ 1 (a contact that fails it, or
//     whose stage is refused for γλ > 1, turns fast for this step and the
//     next kFastHold − 1, and the step is retried at the same H — unless
//     that leaves too few fast contacts: then the coarse norm alone holds,
//     or the refused stage shrinks the step); each fast contact's sub-steps
//     ≤ 1 on their own; the coupling and the miss ≤ 1. A step after a failed
//     attempt does not grow; one that would grow by less than kKeepStep
//     keeps its size (and the lattice's factorization).
//  6. The fast contacts' in-plane u, w at t + H are their sub-steps'; their
//     dissipation (integrated on the sub-steps) joins the quadrature. The
//     lattice worked on the stand-ins along the coarse path instead: the
//     gap is energy the partition makes (SolverStats::partition_work): the
//     energy audit's residual where slips are lone, a part of it in block
//     slips.
//
// Outputs inside a step are interpolated (cubic Hermite; a fast contact's from
// its sub-steps), and stick/slip events are located on the fine solution of a
// fast contact, on the coarse one of a slow contact. Nothing here knows of
// SUNDIALS but the table it loads.

#include <memory>
#include <span>
#include <vector>

#include "stickslip/integrate/contact_substeps.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/integrate/speed_peaks.hpp"

namespace stickslip {

class MultirateIntegrator final : public Integrator {
 public:
  MultirateIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                      double t0, double t_stop, IntegratorOptions options);
  ~MultirateIntegrator() override;

  double advance(double t_out, std::span<double> y) override;
  std::span<const int> roots() const override { return roots_; }
  std::span<const double> peak_speeds() const override { return peaks_.peaks(); }
  SolverStats stats() const override;
  nlohmann::json description() const override;

  // Coupling iterations (steps 2–4 above) allowed in one coarse step.
  static constexpr int kCouplingIterations = 4;
  // The coupling error (step 4, weighted) a fast contact may carry: like a
  // local error, 1. At 0.1 a 15×15 block slip took 36 % more coarse steps
  // and was no more accurate against a converged run (docs/PERFORMANCE.md).
  static constexpr double kCouplingTolerance = 1.0;
  // After a step with contacts apart, the next steps them apart down to
  // multirate_min_fast / kStayApart of them (fast_contacts). At 8: a 30×30
  // block slip 1.34× faster (61.3 against 82 s), the whole 15×15 theta05
  // run 1.14× (35.7 against 40.6 s); at 16, 36.3 s (docs/PERFORMANCE.md).
  static constexpr long kStayApart = 8;
  // A coarse step that could grow by a factor in [1, kKeepStep] keeps its
  // size, as ARKODE's fixed-step bounds (the same [1, 1.5]) keep dirk's: a
  // new H means a new γ, and LatticeSolver::set_gamma refactors every mode
  // and rebuilds the surface Green's function. Whole theta05 1.09× faster,
  // its block slip 1.09×, the 30×30 one 1.04× (docs/PERFORMANCE.md).
  static constexpr double kKeepStep = 1.5;
  // A lone fast contact (at most kLoneNeighbours other contacts among the
  // eight sites around its own) counts kLoneShare times toward
  // multirate_min_fast (fast_contacts). On a 60×60×10 θ = 0.04 window: 1.16×
  // with none around it, 1.32× with at most one (docs/PERFORMANCE.md).
  static constexpr long kLoneShare = 8;
  static constexpr int kLoneNeighbours = 1;

  // What each contact counts toward `min_fast` when it is fast
  // (fast_contacts): 1, a lone one kLoneShare, and `min_fast` itself (one
  // lone slip alone goes apart) where at least half the contacts are lone
  // and all of them, so counted, reach min_fast. There each lone slip
  // collapsed the single-rate step, and stepping it apart paid at the same
  // rtol: 60x60x10 θ = 0.04 window 1.09x, 30x30 1.34x, 15x15 (9 contacts)
  // 1.14x (though on 15x15 no faster than dirk at equal accuracy, so `auto`
  // leaves that to dirk); where few are lone it cost (15x15 θ = 0.498,
  // 3.5 % lone: 1.35x slower), and so on a pair, whose 16 falls short of
  // the default 64 (docs/PERFORMANCE.md).
  static std::vector<long> contact_weights(const System& system, long min_fast);

 private:
  struct Step;  // one accepted coarse step: what outputs and events read
  enum class Attempt { accepted, retry, shrink };

  double advance_to(double t_out, std::span<double> y);
  Attempt attempt(double H);
  void begin_step_derivative();
  void accept(double H);
  double partition_work(const Step& st, bool cancel_own) const;
  std::vector<std::size_t> fast_contacts(double H) const;
  void interpolate(double t, std::span<double> y) const;
  // The earliest stick/slip crossing of a watched contact in (t_from, t_to];
  // false if none.
  bool next_root(double t_from, double t_to, double& t_root);
  void record(double error);
  // The watched contacts' speeds along the step just accepted (peaks_).
  void sample_speeds();

  const System& system_;
  SolverParams solver_;
  IntegratorOptions options_;
  EsdirkTable table_;
  std::vector<NodeCoupling> couplings_;
  std::vector<double> atol_;
  LatticeStageSolver stages_;
  std::size_t n_;  // state size
  double t_stop_;
  long poll_steps_;

  // The state at the end of the last accepted step, t_, and what the next
  // step starts from: the lattice's part of f there (u' = w, a_L, P_in,
  // the lattice's D, F_f) and each site's a_c as its last stage solve had it.
  double t_;
  std::vector<double> y_, lattice_f_;
  std::vector<std::array<double, 2>> contact_a_;
  double h_;                     // the next coarse step
  std::vector<double> substep_;  // each site's next sub-step
  // Steps each contact stays fast after a coarse attempt could not follow it
  // (its own error or γλ): without this every step finds out again, one
  // failed coarse attempt per contact.
  std::vector<int> forced_fast_;
  std::vector<long> weight_;  // per site: its count toward multirate_min_fast
  static constexpr int kFastHold = 3;
  std::unique_ptr<Step> step_, trial_;  // the last accepted step, and the one being tried
  // z_ holds every stage of the attempt that the next one retries (attempt:
  // the next attempt's first Φ).
  bool retry_stages_known_ = false;

  // Events.
  std::vector<int> roots_;
  std::vector<int> sign_;  // each watched contact's side at t_reached_: +1 slipping
  double t_reached_;       // the last time advance() returned
  // Each watched contact's speed at every sub-step end while it is fast, at
  // the coarse step's end while it is slow, and wherever next_root evaluates it.
  SpeedPeaks peaks_;

  // Scratch.
  std::vector<double> b_, weights_, error_;
  std::vector<std::vector<double>> f_;  // stage derivatives
  std::vector<std::vector<double>> z_;  // stage values

  SolverStats stats_;
  long steps_since_poll_ = 0;
};

}  // namespace stickslip
