// Event statistics and synchronization on synthetic events and traces whose
// answers are known exactly. Times are mostly binary fractions, so most
// results must come out exact, not merely close.
#include <catch2/catch.hpp>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "stickslip/core/events.hpp"

using namespace stickslip;

namespace {

Event slip(double t, int contact = 0) {
  return {t, contact, EventKind::slip, 0.0, 0.0};
}
Event stick(double t, int contact = 0) {
  return {t, contact, EventKind::stick, 0.0, 0.0};
}

// Slips of `contact` at first, first + period, … (count of them), each lasting `duration`.
void add_periodic(std::vector<Event>& events, int contact, double first, double period, int count,
                  double duration) {
  for (int k = 0; k < count; ++k) {
    events.push_back(slip(first + k * period, contact));
    events.push_back(stick(first + k * period + duration, contact));
  }
}

}  // namespace

TEST_CASE("periodic slips: recurrence, zero spread, duration, slipping fraction", "[analysis]") {
  std::vector<Event> events;
  add_periodic(events, 0, 0.125, 0.25, 4, 0.0625);
  // Another contact's events, interleaved in time, must be ignored.
  add_periodic(events, 1, 0.0625, 0.125, 8, 0.03125);
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.t < b.t; });

  const ContactEventStats s = contact_statistics(events, 0, false, 0.0, 1.0);
  CHECK(s.contact == 0);
  CHECK(s.slips == 4);
  CHECK(s.mean_recurrence == 0.25);
  CHECK(s.std_recurrence == 0.0);
  CHECK(s.mean_slip_duration == 0.0625);
  CHECK(s.slipping_fraction == 0.25);

  const ContactEventStats other = contact_statistics(events, 1, false, 0.0, 1.0);
  CHECK(other.slips == 8);
  CHECK(other.mean_recurrence == 0.125);
  CHECK(other.slipping_fraction == 0.25);
}

TEST_CASE("irregular slips: population standard deviation of the intervals", "[analysis]") {
  // Intervals 0.25 and 0.5: mean 0.375, population std 0.125 (sample std would be √2·0.125).
  std::vector<Event> events{slip(0.0),    stick(0.125), slip(0.25),
                            stick(0.375), slip(0.75),   stick(0.875)};
  const ContactEventStats s = contact_statistics(events, 0, false, 0.0, 1.0);
  CHECK(s.slips == 3);
  CHECK(s.mean_recurrence == 0.375);
  CHECK(s.std_recurrence == Approx(0.125).epsilon(1e-15));
}

TEST_CASE("window edges: slips spanning t_from and t_to count partially", "[analysis]") {
  // Slip 0.875–1.125 spans t_from = 1, 1.5–1.625 lies inside, 1.9375–2.125 spans t_to = 2.
  const std::vector<Event> events{slip(0.875),  stick(1.125), slip(1.5),
                                  stick(1.625), slip(1.9375), stick(2.125)};
  const ContactEventStats s = contact_statistics(events, 0, false, 1.0, 2.0);
  CHECK(s.slips == 2);  // the one under way at t_from started before the window
  CHECK(s.mean_recurrence == 0.4375);
  CHECK(s.std_recurrence == 0.0);
  CHECK(s.mean_slip_duration == 0.125);  // only the slip that also ends inside
  CHECK(s.slipping_fraction == 0.125 + 0.125 + 0.0625);

  // Widening the window to take in the last stick completes the last slip too.
  const ContactEventStats wide = contact_statistics(events, 0, false, 1.0, 2.25);
  CHECK(wide.mean_slip_duration == (0.125 + 0.1875) / 2);
  CHECK(wide.slipping_fraction == Approx((0.125 + 0.125 + 0.1875) / 1.25).epsilon(1e-15));

  // Events exactly on the edges are inside the window.
  const ContactEventStats edges = contact_statistics(events, 0, false, 1.5, 1.9375);
  CHECK(edges.slips == 2);
  CHECK(edges.mean_recurrence == 0.4375);
}

TEST_CASE("state at t_from follows slipping_at_start and earlier events", "[analysis]") {
  // Slipping from t = 0 until the stick at 0.25; slips again 0.5–0.75.
  const std::vector<Event> events{stick(0.25), slip(0.5), stick(0.75)};
  const ContactEventStats from_slip = contact_statistics(events, 0, true, 0.0, 1.0);
  CHECK(from_slip.slipping_fraction == 0.5);
  CHECK(from_slip.slips == 1);
  CHECK(std::isnan(from_slip.mean_recurrence));  // one slip: no interval
  CHECK(std::isnan(from_slip.std_recurrence));
  CHECK(from_slip.mean_slip_duration == 0.25);

  // Stuck at the start: the first stick event changes nothing.
  CHECK(contact_statistics(events, 0, false, 0.0, 1.0).slipping_fraction == 0.25);
  // The initial slip partly inside the window.
  CHECK(contact_statistics(events, 0, true, 0.125, 1.0).slipping_fraction ==
        Approx(0.375 / 0.875).epsilon(1e-15));

  // From t_from = 0.625 the contact is slipping because of the slip at 0.5,
  // whatever it did at t = 0.
  for (bool start : {false, true}) {
    const ContactEventStats late = contact_statistics(events, 0, start, 0.625, 1.0);
    CHECK(late.slipping_fraction == Approx(1.0 / 3.0).epsilon(1e-15));
    CHECK(late.slips == 0);
    CHECK(std::isnan(late.mean_slip_duration));  // its slip started before the window
  }
}

TEST_CASE("no events: the state at the start holds throughout", "[analysis]") {
  const std::vector<Event> none;
  const ContactEventStats stuck = contact_statistics(none, 3, false, 0.0, 1.0);
  CHECK(stuck.contact == 3);
  CHECK(stuck.slips == 0);
  CHECK(stuck.slipping_fraction == 0.0);
  CHECK(std::isnan(stuck.mean_slip_duration));
  CHECK(contact_statistics(none, 3, true, 0.0, 1.0).slipping_fraction == 1.0);
  CHECK_THROWS_AS(contact_statistics(none, 3, false, 1.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(contact_statistics(none, 3, false, 1.0, 0.5), std::invalid_argument);
}

TEST_CASE("slip rate ratio: b slipping twice as often as a gives 2", "[analysis]") {
  std::vector<Event> events;
  add_periodic(events, 0, 0.25, 0.25, 4, 0.0625);     // 0.25 … 1.0
  add_periodic(events, 1, 0.125, 0.125, 8, 0.03125);  // 0.125 … 1.0
  // A slip of b outside the window does not count.
  events.push_back(slip(1.5, 1));
  const Synchronization s = synchronization(events, 0, 1, 1e-3, 0.0, 1.125, {}, {}, {});
  CHECK(s.contact_a == 0);
  CHECK(s.contact_b == 1);
  CHECK(s.slip_rate_ratio == 2.0);
  CHECK(synchronization(events, 1, 0, 1e-3, 0.0, 1.125, {}, {}, {}).slip_rate_ratio == 0.5);
  // a has no slip in the window: undefined.
  const Synchronization none = synchronization(events, 0, 1, 1e-3, 1.25, 2.0, {}, {}, {});
  CHECK(std::isnan(none.slip_rate_ratio));
  CHECK(std::isnan(none.lag_mean));
  CHECK(std::isnan(none.coincident_fraction));
}

TEST_CASE("lags: b always 3 µs after a", "[analysis]") {
  std::vector<Event> events;
  for (int k = 1; k <= 10; ++k) {
    const double ta = k * 2.8e-4;
    events.push_back(slip(ta, 0));
    events.push_back(stick(ta + 3e-6, 0));
    // b slips 3 µs later, and once more 20 µs earlier: the nearest one counts.
    events.push_back(slip(ta - 2e-5, 1));
    events.push_back(slip(ta + 3e-6, 1));
    events.push_back(stick(ta + 1e-6, 1));  // sticks are not slips
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.t < b.t; });

  const Synchronization wide = synchronization(events, 0, 1, 5e-6, 0.0, 3e-3, {}, {}, {});
  CHECK(wide.lag_mean == Approx(3e-6).margin(1e-18));
  CHECK(wide.lag_min == Approx(3e-6).margin(1e-18));
  CHECK(wide.lag_max == Approx(3e-6).margin(1e-18));
  CHECK(wide.window == 5e-6);
  CHECK(wide.coincident_fraction == 1.0);
  CHECK(wide.slip_rate_ratio == 2.0);
  CHECK_FALSE(wide.xcorr_peak);  // no traces
  CHECK_FALSE(wide.xcorr_lag);

  const Synchronization narrow = synchronization(events, 0, 1, 1e-6, 0.0, 3e-3, {}, {}, {});
  CHECK(narrow.coincident_fraction == 0.0);
  CHECK(narrow.lag_mean == Approx(3e-6).margin(1e-18));
}

TEST_CASE("lags: signed, nearest slip of b at any time, NaN if b never slips", "[analysis]") {
  // Lags +0.25, −0.125, +0.5 (the last partner lies after the window).
  const std::vector<Event> events{slip(1.0, 0),   slip(1.25, 1), slip(2.0, 0),
                                  slip(1.875, 1), slip(3.0, 0),  slip(3.5, 1)};
  const Synchronization s = synchronization(events, 0, 1, 0.25, 0.5, 3.0, {}, {}, {});
  CHECK(s.lag_min == -0.125);
  CHECK(s.lag_max == 0.5);
  CHECK(s.lag_mean == Approx((0.25 - 0.125 + 0.5) / 3).epsilon(1e-15));
  CHECK(s.coincident_fraction == Approx(2.0 / 3.0).epsilon(1e-15));  // |lag| ≤ window counts
  CHECK(s.slip_rate_ratio == Approx(2.0 / 3.0).epsilon(1e-15));

  const std::vector<Event> only_a{slip(1.0, 0), slip(2.0, 0)};
  const Synchronization lonely = synchronization(only_a, 0, 1, 0.25, 0.0, 3.0, {}, {}, {});
  CHECK(std::isnan(lonely.lag_mean));
  CHECK(std::isnan(lonely.lag_min));
  CHECK(std::isnan(lonely.lag_max));
  CHECK(lonely.coincident_fraction == 0.0);
  CHECK(lonely.slip_rate_ratio == 0.0);
}

namespace {

// A train of 3-sample pulses every 150 samples on n samples at dt, cyclically
// shifted by `shift` samples (b_i = a_{i−shift}: positive shift delays it).
std::vector<double> pulse_train(int n, int shift) {
  std::vector<double> v(static_cast<std::size_t>(n), 1e-6);  // creep between slips
  for (int i = 0; i < n; ++i) {
    const int j = ((i - shift) % n + n) % n;
    if (j % 150 < 3) v[static_cast<std::size_t>(i)] = j % 150 == 1 ? 0.16 : 0.05;
  }
  return v;
}

std::vector<double> grid(int n, double dt) {
  std::vector<double> t(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) t[static_cast<std::size_t>(i)] = i * dt;
  return t;
}

}  // namespace

TEST_CASE("cross-correlation: a pulse train and its shift peak at 1 at the shift", "[analysis]") {
  const int n = 1200;
  const double dt = 1e-6;
  const auto t = grid(n, dt);
  const auto a = pulse_train(n, 0);
  const std::vector<Event> none;
  const double t_to = (n - 1) * dt;

  for (int k : {0, 7, -5, 40}) {
    INFO("shift " << k << " samples");
    const auto b = pulse_train(n, k);
    const Synchronization s = synchronization(none, 0, 1, 5e-6, 0.0, t_to, t, a, b);
    REQUIRE(s.xcorr_peak);
    REQUIRE(s.xcorr_lag);
    CHECK(*s.xcorr_peak == Approx(1.0).epsilon(1e-12));
    CHECK(*s.xcorr_lag == Approx(k * dt).margin(1e-12));
  }

  // The lag searched is at most 0.1 ms (100 samples here): a single pulse
  // delayed by 90 samples is found, one delayed by 120 is not.
  auto single = [&](int at) {
    std::vector<double> v(static_cast<std::size_t>(n), 0.0);
    v[static_cast<std::size_t>(at)] = 0.16;
    return v;
  };
  const auto pulse = single(300);
  const Synchronization near = synchronization(none, 0, 1, 5e-6, 0.0, t_to, t, pulse, single(390));
  REQUIRE(near.xcorr_peak);
  CHECK(*near.xcorr_peak == Approx(1.0).epsilon(1e-12));
  CHECK(*near.xcorr_lag == Approx(90 * dt).margin(1e-12));
  const Synchronization far = synchronization(none, 0, 1, 5e-6, 0.0, t_to, t, pulse, single(420));
  REQUIRE(far.xcorr_peak);
  CHECK(*far.xcorr_peak < 0.5);
  CHECK(std::abs(*far.xcorr_lag) <= 1e-4 + 1e-12);
}

TEST_CASE("cross-correlation: only the time window counts", "[analysis]") {
  const int n = 1200;
  const double dt = 1e-6;
  const auto t = grid(n, dt);
  const auto a = pulse_train(n, 0);
  auto b = pulse_train(n, 7);
  // Outside [0.2 ms, 1 ms] b is unrelated to a: the correlation must not see it.
  for (int i = 0; i < n; ++i)
    if (t[static_cast<std::size_t>(i)] < 2e-4 - 1e-12 ||
        t[static_cast<std::size_t>(i)] > 1e-3 + 1e-12)
      b[static_cast<std::size_t>(i)] = std::sin(0.37 * i) * 0.2;
  const std::vector<Event> none;
  const Synchronization inside =
      synchronization(none, 0, 1, 5e-6, 2e-4 - 1e-12, 1e-3 + 1e-12, t, a, b);
  REQUIRE(inside.xcorr_peak);
  CHECK(*inside.xcorr_peak == Approx(1.0).epsilon(1e-12));
  CHECK(*inside.xcorr_lag == Approx(7 * dt).margin(1e-12));
  const Synchronization whole = synchronization(none, 0, 1, 5e-6, 0.0, (n - 1) * dt, t, a, b);
  REQUIRE(whole.xcorr_peak);
  CHECK(*whole.xcorr_peak < 0.99);
}

TEST_CASE("cross-correlation: absent without traces, rejected if lengths differ", "[analysis]") {
  const std::vector<Event> none;
  const Synchronization s = synchronization(none, 0, 1, 5e-6, 0.0, 1.0, {}, {}, {});
  CHECK_FALSE(s.xcorr_peak);
  CHECK_FALSE(s.xcorr_lag);
  const std::vector<double> t{0.0, 1.0, 2.0}, v{1.0, 2.0, 3.0}, short_v{1.0, 2.0};
  CHECK_THROWS_AS(synchronization(none, 0, 1, 5e-6, 0.0, 2.0, t, v, short_v),
                  std::invalid_argument);
  // Constant traces have no defined correlation.
  const std::vector<double> flat{2.0, 2.0, 2.0};
  CHECK_FALSE(synchronization(none, 0, 1, 5e-6, 0.0, 2.0, t, flat, v).xcorr_peak);
}

TEST_CASE("to_json: every field, NaN and absent values as null", "[analysis]") {
  const std::vector<Event> events{slip(0.25, 0), stick(0.5, 0), slip(0.375, 1)};
  const nlohmann::json c = to_json(contact_statistics(events, 0, false, 0.0, 1.0));
  CHECK(c["contact"] == 0);
  CHECK(c["slips"] == 1);
  CHECK(c["mean_recurrence"].is_null());
  CHECK(c["std_recurrence"].is_null());
  CHECK(c["mean_slip_duration"] == 0.25);
  CHECK(c["slipping_fraction"] == 0.25);

  const nlohmann::json s = to_json(synchronization(events, 0, 1, 0.25, 0.0, 1.0, {}, {}, {}));
  CHECK(s["contact_a"] == 0);
  CHECK(s["contact_b"] == 1);
  CHECK(s["slip_rate_ratio"] == 1.0);
  CHECK(s["lag_mean"] == 0.125);
  CHECK(s["lag_min"] == 0.125);
  CHECK(s["lag_max"] == 0.125);
  CHECK(s["coincidence_window"] == 0.25);  // a time; events.window is an interval
  CHECK_FALSE(s.contains("window"));
  CHECK(s["coincident_fraction"] == 1.0);
  CHECK(s["xcorr_peak"].is_null());
  CHECK(s["xcorr_lag"].is_null());
  CHECK(s.dump().find("NaN") == std::string::npos);

  const std::vector<double> t{0.0, 1.0, 2.0, 3.0}, v{0.0, 1.0, 0.0, 0.0};
  const nlohmann::json x = to_json(synchronization(events, 0, 1, 0.25, 0.0, 3.0, t, v, v));
  CHECK(x["xcorr_peak"] == 1.0);
  CHECK(x["xcorr_lag"] == 0.0);
  CHECK(x.size() == 10);
}
