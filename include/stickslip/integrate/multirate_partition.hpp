#pragma once
// The partition rule of method = "multirate" (multirate_integrator.hpp, step
// 1), with everything it reads and sets in one place: which contacts a coarse
// step of size H leaves to their own sub-steps.
//
// A contact is fast when the coarse step cannot follow it: it slips
// (|s| > κ v*, MODEL.md §9), or its speed changes by more than a factor e
// over H (|s·a|/|s|² H > 1, a the node's whole acceleration at the step's
// start: an onset, an arrest), or an attempt at this step or at one of the
// last kFastHold steps found its own error above 1 or refused its stage for
// γλ > 1 (hold_fast). Fewer than [solver] multirate_min_fast of them, each
// counted by its weight (contact_weights), and the step is single rate: on
// 15x15x10 (theta05, 112 contacts) the whole run took 96.0 s with every fast
// contact stepped apart, 79.0 / 77.9 / 70.0 / 60.9 / 57.2 s from 4 / 8 / 16 /
// 32 / 64 on, and dirk 70.3 s (docs/notes/performance-history.md). After a step with
// contacts apart the bar is kStayApart times lower.

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "stickslip/model/system.hpp"

namespace stickslip {

class MultiratePartition {
 public:
  // After a step with contacts apart, the next steps them apart down to
  // min_fast / kStayApart of them: a block slip's tail of arrests, each of
  // which collapses a single-rate step, comes after the slip proper (the
  // loading's small clusters still step single rate, where stepping them
  // apart cost more). At 8: a 30×30 block slip 1.34× faster (61.3 against
  // 82 s), the whole 15×15 theta05 run 1.14× (35.7 against 40.6 s); at 16,
  // 36.3 s (docs/notes/performance-history.md).
  static constexpr long kStayApart = 8;
  // A lone fast contact (at most kLoneNeighbours other contacts among the
  // eight sites around its own) counts kLoneShare times toward min_fast: it
  // turns few slow neighbours fast under its slip, so it is cheap to step
  // apart, while lone slips each collapsed the single-rate step. On a
  // 60×60×10 θ = 0.04 window: 1.16× with none around it, 1.32× with at most
  // one (docs/notes/performance-history.md).
  static constexpr long kLoneShare = 8;
  static constexpr int kLoneNeighbours = 1;
  // Steps a contact stays fast after a coarse attempt could not follow it
  // (its own error or γλ): without the hold every step finds out again, one
  // failed coarse attempt per contact.
  static constexpr int kFastHold = 3;

  MultiratePartition(const System& system, long min_fast);

  // What each contact counts toward `min_fast` when it is fast: 1, a lone
  // one kLoneShare, and `min_fast` itself (one lone slip alone goes apart)
  // where at least half the contacts are lone and all of them, so counted,
  // reach min_fast. There each lone slip collapsed the single-rate step, and
  // stepping it apart paid at the same rtol: 60x60x10 θ = 0.04 window 1.09x,
  // 30x30 1.34x, 15x15 (9 contacts) 1.14x (though on 15x15 no faster than
  // dirk at equal accuracy, so `auto` leaves that to dirk); where few are
  // lone it cost (15x15 θ = 0.498, 3.5 % lone: 1.35x slower), and so on a
  // pair, whose 16 falls short of the default 64 (docs/notes/performance-history.md).
  static std::vector<long> contact_weights(const System& system, long min_fast);

  // The fast contacts (sites, increasing) of a coarse step of size H from
  // the state y at its start, where the lattice's part of f is lattice_f and
  // each site's contact acceleration contact_a; none if they count fewer
  // than the bar. `after_step_apart`: the last accepted step had contacts
  // apart.
  std::vector<std::size_t> fast_contacts(double H, std::span<const double> y,
                                         std::span<const double> lattice_f,
                                         std::span<const std::array<double, 2>> contact_a,
                                         bool after_step_apart) const;

  // Site j turns fast for this step and the next kFastHold − 1.
  void hold_fast(std::size_t j) { forced_fast_[j] = kFastHold; }
  // A coarse step was accepted: the holds count down.
  void step_accepted();

  long min_fast() const { return min_fast_; }

 private:
  const System& system_;
  long min_fast_;
  std::vector<long> weight_;      // per site: its count toward min_fast
  std::vector<int> forced_fast_;  // per site: steps it stays fast (hold_fast)
};

}  // namespace stickslip
