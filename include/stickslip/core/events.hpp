#pragma once
// Stick/slip events and what is derived from them: per-contact statistics and
// the synchronization of two contacts (MODEL.md §9, §11 Fig. 10). Pure
// post-processing on plain data: it knows nothing of the integrator.

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace stickslip {

enum class EventKind { slip, stick };  // slip: |s| rises through κ v*; stick: falls through it

// "slip" / "stick", as in events.csv.
std::string_view to_string(EventKind kind);
// The inverse of to_string; empty for anything else.
std::optional<EventKind> parse_event_kind(std::string_view text);

struct Event {
  double t = 0.0;   // [s]
  int contact = 0;  // contact id
  EventKind kind = EventKind::slip;
  // Where the event was located rather than a measurement: |s| is κ v* there
  // (to the root finder's tolerance), so for a single-site contact the force
  // is the same at every event. slips.csv has what changes (recorders.cpp).
  double speed = 0.0;  // |s| at the event [m/s]
  double force = 0.0;  // magnitude of the contact force at the event [N]
};

struct ContactEventStats {
  int contact = 0;
  long slips = 0;                   // slip events in [t_from, t_to]
  double mean_recurrence = 0.0;     // mean interval between successive slip events [s]
  double std_recurrence = 0.0;      // its standard deviation [s]
  double mean_slip_duration = 0.0;  // mean time from a slip event to the next stick [s]
  double slipping_fraction = 0.0;   // fraction of [t_from, t_to] spent slipping
};

// Statistics of one contact over the window [t_from, t_to]. `events` holds
// that contact's events in time order (others are ignored);
// `slipping_at_start` is its state at t = 0. Intervals and durations that are
// not defined (fewer than two slips, no completed slip) are NaN. Events at
// exactly t_from or t_to are inside the window. Throws std::invalid_argument
// unless t_from < t_to.
ContactEventStats contact_statistics(std::span<const Event> events, int contact,
                                     bool slipping_at_start, double t_from, double t_to);

struct Synchronization {
  int contact_a = 0, contact_b = 0;
  double slip_rate_ratio = 0.0;  // slips of b per slip of a, in the window
  // For each slip of a, the signed lag t_b − t_a to the nearest slip of b [s].
  double lag_mean = 0.0, lag_min = 0.0, lag_max = 0.0;
  double window = 0.0;               // coincidence window [s]
  double coincident_fraction = 0.0;  // slips of a with a slip of b within ±window
  // Cross-correlation of the two contacts' x-velocity traces (if traced).
  std::optional<double> xcorr_peak;  // normalized, in [−1, 1]
  std::optional<double> xcorr_lag;   // lag of the peak, b relative to a [s]
};

// Synchronization of contacts a and b over [t_from, t_to]. `t`, `va`, `vb`
// are their x-velocity traces on a common uniform grid (empty if not traced).
// Lags and coincidences are NaN when a has no slip in the window (lags also
// when b never slips). Throws std::invalid_argument unless t_from < t_to and
// the three traces have the same length. Details in events.cpp.
Synchronization synchronization(std::span<const Event> events, int contact_a, int contact_b,
                                double window, double t_from, double t_to,
                                std::span<const double> t, std::span<const double> va,
                                std::span<const double> vb);

nlohmann::json to_json(const ContactEventStats& s);
nlohmann::json to_json(const Synchronization& s);

}  // namespace stickslip
