// The regression tier (ctest -L regression, ~20 s on one core): event
// statistics of a small stick-slip case — slip counts, slip times, the mean
// recurrence interval, peak slip speeds, μ — never trajectories point by point
// (STYLE.md: stick-slip is chaotic, and golden files break on any change of
// the step sequence). Two kinds of check:
//   - the run at the default tolerance against the same case at rtol 1e-8,
//     computed here, with tolerances from the tolerance study
//     (docs/notes/performance-history.md) and the ladder measured on this case (below);
//   - the run against what MODEL.md predicts without integrating: the load a
//     stuck contact carries, and the friction law's limits.
//
// The case: one contact, the weak one of Fig. 10 (v* = 4.75e-4 m/s below the
// drive's 1e-3 m/s: it stick-slips), on 6×6×4, from rest over 2 ms: five
// slips, the first at 0.662 ms, then every 0.276 or 0.298 ms (the intervals
// alternate), each ~3 µs long and peaking at 0.162–0.164 m/s.
//
// Measured on this case (code of this commit; rtol with both absolute
// tolerances scaled alike, 1e-8 as the reference):
//
//   rtol  | slips | worst slip time | mean recurrence | worst peak speed | μ
//   1e-4  |  10   |  –              |  –              |  –               | 1.7e-2
//   1e-5  |   5   | 2.5e-5 s        | 2.2e-2          | 5.0e-2           | 1.6e-3
//   1e-6  |   5   | 5.5e-9 s        | 5.1e-6          | 1.5e-5           | 8.0e-6
//   1e-7  |   5   | 3.8e-9 s        | 3.8e-6          | 5.1e-6           | 1.5e-6
//
// (relative differences but the slip times). Every tolerance below sits
// between the default's error and rtol 1e-5's, so each check fails if the
// default run becomes as inaccurate as one ten times looser.
#include <Eigen/Dense>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

Case one_contact() {
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.contacts = {{2, 3, 4.75e-4, 0}};
  c.drive.velocity = 1e-3;
  c.run.t_end = 2e-3;
  c.run.average_from = 5e-4;
  return c;
}

// The same solver with rtol scaled by `factor` (the absolute tolerances
// follow it), on dirk, the method of the converged references
// (docs/notes/performance-history.md; imex at these tolerances takes minutes).
SolverParams tightened(SolverParams p, double factor) {
  p.method = Method::dirk;
  p.rtol *= factor;
  return p;
}

struct Slip {
  double onset = 0.0;       // the stick→slip event [s]
  double u_contact = 0.0;   // the contact's u^x then [m]
  double peak_speed = 0.0;  // its largest |s| until the slip→stick event [m/s]
};

struct Observation {
  std::vector<Slip> slips;
  double mu = 0.0;  // over [average_from, t_end], from the friction impulse as run_case has it
};

// Sampling while a contact slips: a slip lasts ~3 µs and its speed peaks
// over ~1 µs, so 2 ns samples of the interpolated state find the peak to
// well under 1e-6 of it.
constexpr double kSlipSampling = 2e-9;  // [s]

// Integrates the case from rest with contact 0 watched, as run_case does:
// events come from root finding; between them the integrator runs to t_avg
// and t_end without intermediate outputs, every kSlipSampling while slipping.
Observation observe(const Case& c, const SolverParams& solver) {
  const System s(c, place_contacts(c.lattice, c.interface));
  std::vector<double> y(static_cast<std::size_t>(s.size()));
  s.initial_state(InitialState::rest, y);
  IntegratorOptions options;
  options.watched_contacts = {0};
  const double t_end = c.run.t_end, t_avg = c.run.average_from;
  const auto integrator = make_integrator(s, solver, y, t_end, options);
  const std::int64_t impulse = s.quadrature_index(System::friction_impulse);
  const std::int64_t ux = s.u_index(s.contact_set().sites()[0].node, 0);
  Observation o;
  double t = 0.0, impulse_at_avg = 0.0;
  bool slipping = false;
  while (t < t_end) {
    double target = slipping ? std::min(t + kSlipSampling, t_end) : t_end;
    if (t < t_avg) target = std::min(target, t_avg);
    t = integrator->advance(target, y);
    if (t == t_avg) impulse_at_avg = y[impulse];
    const auto s_c = s.contact_set().contact_velocity(0, y);
    const double speed = std::hypot(s_c[0], s_c[1]);
    if (integrator->roots()[0] > 0) {
      slipping = true;
      o.slips.push_back({t, y[static_cast<std::size_t>(ux)], speed});
    } else if (integrator->roots()[0] < 0) {
      slipping = false;
    }
    if (!o.slips.empty()) o.slips.back().peak_speed = std::max(o.slips.back().peak_speed, speed);
  }
  o.mu = (y[impulse] - impulse_at_avg) / ((t_end - t_avg) * s.normal_force());
  return o;
}

// The slips whose onset lies in [from, to].
std::vector<Slip> slips_in(const Observation& o, double from, double to) {
  std::vector<Slip> out;
  for (const Slip& slip : o.slips)
    if (slip.onset >= from && slip.onset <= to) out.push_back(slip);
  return out;
}

// The mean interval between successive onsets of `slips` [s].
double mean_recurrence(const std::vector<Slip>& slips) {
  return (slips.back().onset - slips.front().onset) / static_cast<double>(slips.size() - 1);
}

double relative(double a, double b) {
  return std::abs(a - b) / std::abs(b);
}

// How the lattice loads a stuck contact (MODEL.md §3–5). The lattice's
// accelerations are affine in (t, u, w): acc = A_u u + A_w w + b0 + b1 t.
// With the contact's u^x held at 0, u = α t + β, w = α solves them exactly
// (ü = 0) once the transient from rest has died out:
//   A_u α + b1 = 0,   A_u β + A_w α + b0 = 0   (on every other component).
// The force that holds the contact, m acc^x there, is then linear in t; and
// since translating the plate and every node together changes no force,
// a contact that has crept to u^x carries
//   F = K (v (t − t_lag) − u^x).
struct Loading {
  double stiffness = 0.0;  // K [N/m]
  double lag = 0.0;        // t_lag [s]: the dashpots' share, for a moving plate
};

Loading quasi_static_loading(const System& s, std::size_t contact) {
  const std::int64_t n3 = 3 * s.num_nodes();
  const auto n = static_cast<std::size_t>(n3);
  const auto held = static_cast<Eigen::Index>(s.u_index(s.contact_set().sites()[contact].node, 0));
  std::vector<double> u(n, 0.0), w(n, 0.0), acc(n);
  auto accelerations = [&](double t) {
    s.lattice_accelerations(t, u, w, acc);
    return Eigen::Map<const Eigen::VectorXd>(acc.data(), n3).eval();
  };
  const Eigen::VectorXd b0 = accelerations(0.0);
  const double t1 = 1e-3;
  const Eigen::VectorXd b1 = (accelerations(t1) - b0) / t1;
  // Columns by unit probes, scaled to the unknowns' sizes (affine: exact to rounding).
  const double du = 1e-6, dw = 1e-3;
  Eigen::MatrixXd a_u(n3, n3), a_w(n3, n3);
  for (std::size_t j = 0; j < n; ++j) {
    u[j] = du;
    a_u.col(static_cast<Eigen::Index>(j)) = (accelerations(0.0) - b0) / du;
    u[j] = 0.0;
    w[j] = dw;
    a_w.col(static_cast<Eigen::Index>(j)) = (accelerations(0.0) - b0) / dw;
    w[j] = 0.0;
  }
  // The system on every component but the held one.
  std::vector<Eigen::Index> free;
  for (Eigen::Index j = 0; j < n3; ++j)
    if (j != held) free.push_back(j);
  const auto m = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd a(m, m);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < m; ++j) a(i, j) = a_u(free[i], free[j]);
  const auto lu = a.partialPivLu();
  auto solve_free = [&](const Eigen::VectorXd& rhs) {
    Eigen::VectorXd r(m);
    for (Eigen::Index i = 0; i < m; ++i) r(i) = rhs(free[i]);
    const Eigen::VectorXd x = lu.solve(r);
    Eigen::VectorXd full = Eigen::VectorXd::Zero(n3);
    for (Eigen::Index i = 0; i < m; ++i) full(free[i]) = x(i);
    return full;
  };
  const Eigen::VectorXd alpha = solve_free(-b1);
  const Eigen::VectorXd beta = solve_free(-(a_w * alpha + b0));
  const double rate = s.mass() * ((a_u * alpha)(held) + b1(held));                          // dF/dt
  const double at_zero = s.mass() * ((a_u * beta)(held) + (a_w * alpha)(held) + b0(held));  // F(0)
  return {rate / s.drive_velocity(), -at_zero / rate};
}

}  // namespace

TEST_CASE("one contact's stick-slip at the default tolerance has the statistics of rtol 1e-8",
          "[regression]") {
  const Case c = one_contact();
  const Observation run = observe(c, c.solver);  // the defaults: auto (dirk here), rtol 1e-6
  const Observation reference = observe(c, tightened(c.solver, 1e-2));
  REQUIRE(reference.slips.size() >= 4);  // the case does stick-slip

  // Slip counts: a run that invents or misses a slip fails (rtol 1e-4 finds 15).
  REQUIRE(run.slips.size() == reference.slips.size());
  for (std::size_t k = 0; k < run.slips.size(); ++k) {
    const Slip &a = run.slips[k], &b = reference.slips[k];
    INFO("slip " << k << ": at " << a.onset << " s, peak " << a.peak_speed << " m/s; reference "
                 << b.onset << " s, " << b.peak_speed << " m/s");
    // Slip times: the tolerance study's event error at the default tolerance
    // is 4.3e-8 s (Fig. 10b, over 1.5 ms); 1e-7 s leaves a factor 2.3 over
    // it and 18 over this case's 5.5e-9 s, and is 250 times below rtol
    // 1e-5's 2.5e-5 s.
    CHECK(std::abs(a.onset - b.onset) <= 1e-7);
    // Peak slip speeds: measured 1.5e-5 at the default, 5.0e-2 at rtol 1e-5
    // (the study's trace error at the default, 3.2e-2 relative L2 on Fig.
    // 10b, is mostly the slips' timing, not their height). 1e-3: 65 times
    // the default's error, 50 times below rtol 1e-5's.
    CHECK(relative(a.peak_speed, b.peak_speed) <= 1e-3);
  }
  // The mean recurrence interval over the averaging window (all 5 slips, 4
  // intervals): the study's event error at the default over one ~0.29 ms
  // interval is 1.5e-4; 2e-4 is 40 times this case's 5.1e-6 and 110 times
  // below rtol 1e-5's 2.2e-2.
  const double t_avg = c.run.average_from, t_end = c.run.t_end;
  const double recurrence = mean_recurrence(slips_in(run, t_avg, t_end));
  const double expected = mean_recurrence(slips_in(reference, t_avg, t_end));
  INFO("mean recurrence " << recurrence << " s, reference " << expected << " s");
  CHECK(relative(recurrence, expected) <= 2e-4);
  // μ: the study's μ error at the default is 1.6e-5 (Fig. 10b), 1.4e-3 at
  // rtol 1e-5; here 8.0e-6 and 1.6e-3. 1e-4 is 6 times the study's and 12
  // times this case's, 16 times below this case's rtol 1e-5.
  INFO("mu " << run.mu << ", reference " << reference.mu);
  CHECK(relative(run.mu, reference.mu) <= 1e-4);
}

TEST_CASE("one contact slips when its quasi-static load reaches the law's peak", "[regression]") {
  const Case c = one_contact();
  const System s(c, place_contacts(c.lattice, c.interface));
  const Observation run = observe(c, c.solver);
  REQUIRE(run.slips.size() >= 4);

  // The contact force where |s| = κ v* (MODEL.md §6, §9), from the case's
  // parameters: ε f0 φ(κ) + m η_c κ v*, f0 = a² τ_f, η_c = η̂_c ω0,
  // ω0 = sqrt(G1 + G2) / a, G1 = E / (2 (1 + ν) ρ), G2 = (1 + 2ν) G1.
  const auto& m = c.material;
  const auto& f = c.interface;
  const double a = c.lattice.spacing, v = c.drive.velocity, v_star = f.contacts[0].v_star;
  const double mass = m.density * a * a * a;
  const double g1 = m.youngs_modulus / (2 * (1 + m.poisson_ratio) * m.density);
  const double g2 = (1 + 2 * m.poisson_ratio) * g1;
  const double eta_c = c.damping.contact * std::sqrt(g1 + g2) / a;
  auto phi = [&](double r) { return std::exp(-f.shape * std::pow(std::log10(r), 2)); };
  const double kappa = f.slip_threshold;
  const double threshold_force =
      f.epsilon * a * a * f.shear_stress * phi(kappa) + mass * eta_c * kappa * v_star;

  // Slip k starts when the load K (v (t − t_lag) − u^x) reaches it: t_k =
  // t_lag + (F / K + u^x(t_k)) / v, u^x(t_k) the contact's creep and earlier
  // slips. Measured (K = 1001 N/m, t_lag = −0.29 µs): the first slip, from
  // rest, 7.5e-4 from its prediction at every rtol from 1e-5 to 1e-8 (the
  // contact's own inertia as it breaks away); the later ones up to 5.5e-3
  // (the block still rings from the slip before). These are the physics'
  // offsets, not the integration's: rtol 1e-4 misses the first by 1.2e-2
  // and a later one by 0.17. Hence 2e-3 for the first (2.7 times its offset)
  // and 1e-2 for the others (1.8 times the worst).
  const Loading load = quasi_static_loading(s, 0);
  for (std::size_t k = 0; k < run.slips.size(); ++k) {
    const Slip& slip = run.slips[k];
    const double predicted = load.lag + (threshold_force / load.stiffness + slip.u_contact) / v;
    INFO("slip " << k << " at " << slip.onset << " s, predicted " << predicted
                 << " s (K = " << load.stiffness << " N/m, t_lag = " << load.lag << " s)");
    CHECK(relative(slip.onset, predicted) <= (k == 0 ? 2e-3 : 1e-2));
  }

  // So the contact advances as far as the plate from one slip to the next
  // (the load is the same at every onset): the mean recurrence interval over
  // the window is the contact's advance over it divided by v. Measured:
  // 2.5e-3 apart (the same ringing; 4.3e-3 at rtol 1e-5). 1e-2 allows 4
  // times the default's; a plate that moved at other than the case's v
  // fails it.
  const auto window = slips_in(run, c.run.average_from, c.run.t_end);
  const double advance = window.back().u_contact - window.front().u_contact;
  const double loading_period = advance / v / static_cast<double>(window.size() - 1);
  INFO("mean recurrence " << mean_recurrence(window) << " s, contact's advance / v "
                          << loading_period << " s");
  CHECK(relative(mean_recurrence(window), loading_period) <= 1e-2);

  // μ between the law's kinetic and static levels. Over the window μ F_N is
  // the mean force the contact carries (momentum balance: the block's
  // momentum and the drive's dashpots average out, MODEL.md §5, §7), and the
  // law lies between its value at the slips' top speed and its peak φ = 1;
  // both plus the contact dashpot at the mean speed v. Measured: 3.41 < 5.18
  // < 6.50. Not tight: it catches a wrong scale of F_f or F_N and slips that
  // overshoot far below the kinetic level.
  double top_speed = 0.0;
  for (const Slip& slip : window) top_speed = std::max(top_speed, slip.peak_speed);
  const double dashpot = mass * eta_c * v / (f.epsilon * f.max_pressure * a * a);
  const double ratio = f.shear_stress / f.max_pressure;
  const double kinetic = ratio * phi(top_speed / v_star) + dashpot;
  const double static_limit = ratio * phi(kappa) + dashpot;
  INFO("mu " << run.mu << ", kinetic " << kinetic << ", static " << static_limit);
  CHECK(run.mu > kinetic);
  CHECK(run.mu < static_limit);
}
