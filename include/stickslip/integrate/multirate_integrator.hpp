#pragma once
// method = "multirate": contacts on their own clocks.
//
// In a block slip every contact's start and stop used to collapse the one
// global step (docs/notes/performance-history.md, "Multirate", "Why"):
// a re-sticking contact's speed halves at every step for ~15 ns, and the
// whole lattice was stepped at 1e-11 s through it. Here a coarse step of
// dirk's ESDIRK advances the lattice and the slow contacts, with the exact
// FFT stage solve (LatticeStageSolver); each fast contact advances on
// sub-steps of its own (ContactSubsteps) with the rest of the lattice's force
// on it given by the coarse level, and hands its impulse back to the coarse
// level. One coarse step:
//
//  1. Partition (MultiratePartition, multirate_partition.hpp): which contacts
//     the coarse step cannot resolve. Too few of them and there are none:
//     the step is single rate, as dirk's.
//  2. Each fast contact's sub-steps over [t, t + H] under Φ(t), the rest of
//     the lattice's acceleration on its node: first Φ's Taylor line at t (in
//     a retry at the same H, the polynomial through Φ along the stages of the
//     attempt it repeats), then the polynomial through the coarse stages, a
//     fast neighbour's part read off that neighbour's sub-steps.
//  3. The coarse ESDIRK step of everything, each fast contact's law replaced
//     by a stand-in: the line ℓ(τ) = p0 + p1 τ with the same ∫ and ∫τ as
//     its sub-steps' a_c + K u + C w (its node's own acceleration, all but
//     Φ; from the second pass ∫τ such that the coarse level's part of the
//     node's displacement in the last pass plus the line's lands on the
//     sub-steps' end), less K u + C w along the coarse path. The coarse node
//     then moves under Φ and ℓ alone, as the sub-steps did under Φ: its
//     neighbours see its impulse and displacement. (Up to γ(−C − γK) = 1/2,
//     H ~ 1 µs; beyond, the line through a_c alone.)
//  4. Error control: the coarse embedded estimate over every component but
//     the fast contacts' in-plane u and w (weighted RMS ≤ 1); each slow
//     contact's own in-plane velocity error ≤ 1 (a contact that fails it, or
//     whose stage is refused for γλ > 1, turns fast for this step and the
//     next kFastHold − 1, and the step is retried at the same H — unless
//     that leaves too few fast contacts: then the coarse norm alone holds,
//     or the refused stage shrinks the step); each fast contact's sub-steps
//     ≤ 1 on their own (2).
//  5. The hand-back: if Φ along the coarse stages differs from the Φ the
//     sub-steps used by more than the tolerance can absorb (H |ΔΦ| weighted,
//     or |ΔΦ|/λ where the contact's own damping λ is faster), or the
//     stand-in's displacement misses the sub-steps' (what the neighbours
//     then felt wrong, weighted), 2–5 again (at most kCouplingIterations
//     passes); the coupling and the miss ≤ 1. A step after a failed attempt
//     does not grow; one that would grow by less than kKeepStep keeps its
//     size (and the lattice's factorization).
//  6. Accept: the fast contacts' in-plane u, w at t + H are their
//     sub-steps'; their dissipation (integrated on the sub-steps) joins the
//     quadrature. The lattice worked on the stand-ins along the coarse path
//     instead: the gap is energy the partition makes
//     (its partition_work, Counts): the energy audit's residual where slips
//     are lone, a part of it in block slips.
//
// Each attempt's outcome (its verdict, errors and worst component) goes to
// IntegratorOptions::on_attempt when a run asks for it ([output] attempts).
// Outputs inside a step are interpolated (cubic Hermite; a fast contact's from
// its sub-steps), and stick/slip events are located on the fine solution of a
// fast contact, on the coarse one of a slow contact. Nothing here knows of
// SUNDIALS but the table it loads.

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "stickslip/integrate/contact_substeps.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/integrate/multirate_partition.hpp"
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

  // Its columns of steps.csv (StepRecord::method_values): the contacts each
  // step left to their own sub-steps, and those sub-steps; and how far a
  // fast contact's coarse node missed its sub-steps' end, as its neighbours
  // felt it, weighted as a local error (≤ 1; 0 where no contact was apart).
  // The record's error is the larger of the miss and the coarse estimate,
  // so it says which of the two sized the step.
  static constexpr std::array<StepColumn, 3> kStepColumns{
      {{"fast_contacts", "", true}, {"substeps", "", true}, {"miss", "1", false}}};

  // Coupling passes (steps 2–5 above) allowed in one coarse attempt.
  static constexpr int kCouplingIterations = 4;
  // The coupling error (step 5, weighted) a fast contact may carry: like a
  // local error, 1. At 0.1 a 15×15 block slip took 36 % more coarse steps
  // and was no more accurate against a converged run (docs/notes/performance-history.md).
  static constexpr double kCouplingTolerance = 1.0;
  // A coarse step that could grow by a factor in [1, kKeepStep] keeps its
  // size, as ARKODE's fixed-step bounds (the same [1, 1.5]) keep dirk's: a
  // new H means a new γ, and LatticeSolver::set_gamma refactors every mode
  // and rebuilds the surface Green's function. Whole theta05 1.09× faster,
  // its block slip 1.09×, the 30×30 one 1.04× (docs/notes/performance-history.md).
  static constexpr double kKeepStep = 1.5;

 private:
  struct Step;      // one coarse step: what outputs and events read once it is accepted
  struct Attempt;   // what one attempt at a coarse step works with, for as long as it runs
  struct Coupling;  // how a fast contact's Φ reads the coarse level and its fast neighbours
  // What an attempt comes to (AttemptRecord::Verdict), and for a retry at the
  // same H the partition it takes and, where the attempt solved every stage,
  // each of its fast contacts' first Φ through them.
  struct Outcome {
    AttemptRecord::Verdict verdict;
    std::string reason;  // a failed stage's or sub-step's own (StageNotConverged)
    std::vector<std::size_t> retry_fast;
    std::vector<Forcing> retry_forcing;  // empty: Φ's Taylor line at t
  };

  double advance_to(double t_out, std::span<double> y);
  void take_step();  // one accepted coarse step, retried and shrunk as it needs
  Outcome attempt(double H, std::optional<Outcome> retry);
  // Steps of attempt() (the header's numbers).
  void begin_attempt(Step& st, double H, std::vector<std::size_t> fast);
  Coupling couple(const std::vector<std::size_t>& fast) const;
  bool cancels_own(double H, const std::vector<std::size_t>& fast) const;
  std::optional<Outcome> substep_fast(Attempt& a);   // 2
  std::optional<Outcome> coarse_stages(Attempt& a);  // 3
  std::optional<Outcome> check_error(Attempt& a);    // 4
  std::optional<Outcome> hand_back(Attempt& a);      // 5
  Forcing forcing_from(const Attempt& a, std::size_t q,
                       const std::vector<SubstepResult>& fine) const;
  std::vector<Forcing> forcing_through_stages(const std::vector<std::size_t>& fast, double H) const;
  double partition_work(const Step& st, bool cancel_own) const;
  void accept();  // 6
  void report(const Attempt& a, const Outcome& o) const;
  void begin_step_derivative();
  void interpolate(double t, std::span<double> y) const;
  // The earliest stick/slip crossing of a watched contact in (t_from, t_to];
  // false if none.
  bool next_root(double t_from, double t_to, double& t_root);
  void record(double error);
  // The watched contacts' speeds along the step just accepted (peaks_).
  void sample_speeds();
  std::string failure(double H) const;

  const System& system_;
  SolverParams solver_;
  IntegratorOptions options_;
  EsdirkTable table_;
  std::vector<NodeCoupling> couplings_;
  std::vector<double> atol_;
  LatticeStageSolver stages_;
  MultiratePartition partition_;
  std::size_t n_;  // state size
  double t_stop_;
  long poll_steps_;

  // The state at the end of the last accepted step, t_, and what the next
  // step starts from: the lattice's part of f there (u' = w, a_L, P_in,
  // the lattice's D, F_f) and each site's a_c as its last stage solve had it.
  double t_;
  std::vector<double> y_, lattice_f_;
  std::vector<std::array<double, 2>> contact_a_;
  double h_;                            // the next coarse step
  std::vector<double> substep_;         // each site's next sub-step
  std::unique_ptr<Step> step_, trial_;  // the last accepted step, and the one being tried
  // The last failed attempt's verdict and reason, for the message if the
  // step then fails for good.
  Outcome last_failure_{AttemptRecord::Verdict::accepted, {}, {}, {}};

  // Events.
  std::vector<int> roots_;
  std::vector<int> sign_;  // each watched contact's side at t_reached_: +1 slipping
  double t_reached_;       // the last time advance() returned
  // Each watched contact's speed at every sub-step end while it is fast, at
  // the coarse step's end while it is slow, and wherever next_root evaluates it.
  SpeedPeaks peaks_;

  // An attempt's workspace: its stage values z and derivatives f, the
  // right-hand sides b, the error weights and the weighted error. Written
  // and read by one attempt only (its Attempt refers to them); kept here so
  // that their memory is reused from one attempt to the next.
  std::vector<double> b_, weights_, error_;
  std::vector<std::vector<double>> f_, z_;

  SolverStats stats_;
  // What only multirate counts (SolverStats::method): the fast contacts'
  // sub-steps (accepted, rejected), the contacts the coarse steps left to
  // them (summed over the steps), the coupling passes repeated, and the
  // energy the partition itself makes [J]: the lattice does work on a fast
  // contact's stand-in along the node's coarse path, the contact dissipates
  // along its sub-steps; where its force changes within a coarse step the
  // two differ. Where slips are lone, this summed over the run is, but for
  // the coarse steps' own error, the energy audit's residual times the
  // drive's work; in block slips it is a part of it (docs/notes/performance-history.md,
  // "The μ floor, what it is and what it is not").
  struct Counts {
    long substeps = 0, substep_failures = 0, fast_contact_steps = 0, coupling_iterations = 0;
    double partition_work = 0.0;
  } counts_;
  long steps_since_poll_ = 0;
};

}  // namespace stickslip
