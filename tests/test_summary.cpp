// summary.json, typed (output/summary.hpp): every field survives writing and
// reading back, undefined numbers travel as null and come back as NaN or
// empty, older summaries without the newer fields still read, and a field
// that is missing or of the wrong type is named.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "stickslip/output/summary.hpp"
#include "stickslip/output/writers.hpp"
#include "temp_dir.hpp"

using namespace stickslip;
namespace fs = std::filesystem;

namespace {

Summary full_summary() {
  Summary s;
  s.mu = 5.25;
  s.mu_error = 0.0625;
  s.mu_error_from = "block cycles";
  s.average_auto = true;
  s.window_samples = 2001;
  s.mu_whole_cycles = WholeCycleMu{5.5, 1.2e-3, 2.9e-3, 7, 2.8e-4, 0.03125};
  s.block_slips = {{1.2e-3, 1.21e-3, 2.5e-4}, {1.48e-3, 1.5e-3, 2.25e-4}};
  s.F_f_spread = 0.125;
  s.regime = WindowRegime{Regime::stick_slip, 0.015, 0.02};
  s.theta = 0.0089;
  s.F_N = 2e-4;
  s.contacts = 2;
  s.t_end = 3e-3;
  s.average_from = 1e-3;
  s.wall_seconds = 19.5;
  s.energy_residual = -7.9e-6;
  s.energy_audit_bound = 1e-4;
  s.steady_sliding_mu = 6.43;
  s.solver = {{"method", "imex"}, {"order", 4}};
  s.solver_stats.steps = 12197;
  s.solver_stats.rhs_implicit = 74181;
  s.solver_stats.last_step = 1.7e-7;
  s.git_commit = "abc123";
  s.sundials_version = "6.4.1";
  s.case_json = {{"run", {{"t_end", 3e-3}}}};
  ContactEventStats never_slipped;  // no recurrence, duration or fraction defined
  never_slipped.contact = 1;
  never_slipped.mean_recurrence = never_slipped.std_recurrence = NAN;
  never_slipped.mean_slip_duration = NAN;
  s.events = EventSummary{50, 1e-3, 3e-3, {{0, 14, 2.8e-4, 1e-6, 5e-5, 0.18}, never_slipped}};
  Synchronization y;
  y.contact_a = 0;
  y.contact_b = 1;
  y.slip_rate_ratio = 1.0;
  y.lag_mean = 7.9e-6;
  y.lag_min = 7.5e-6;
  y.lag_max = 1.1e-5;
  y.window = 1.2e-5;
  y.coincident_fraction = 1.0;
  y.xcorr_lag = 8e-6;  // xcorr_peak left empty
  s.synchronization = y;
  return s;
}

}  // namespace

TEST_CASE("a summary reads back field for field through its JSON", "[summary]") {
  const Summary a = full_summary();
  const nlohmann::json j = to_json(a);
  CHECK(j["events"]["per_contact"][1]["mean_recurrence"].is_null());  // NaN is null in JSON
  CHECK(j["synchronization"]["xcorr_peak"].is_null());
  Summary b = summary_from_json(nlohmann::json::parse(j.dump()));
  CHECK(b.mu == a.mu);
  REQUIRE(b.mu_whole_cycles);
  CHECK(b.mu_whole_cycles->mu == 5.5);
  CHECK(b.mu_whole_cycles->from == 1.2e-3);
  CHECK(b.mu_whole_cycles->to == 2.9e-3);
  CHECK(b.mu_whole_cycles->block_slips == 7);
  CHECK(b.mu_whole_cycles->period == 2.8e-4);
  CHECK(b.mu_whole_cycles->error == 0.03125);
  CHECK(b.mu_error == 0.0625);
  CHECK(b.mu_error_from == "block cycles");
  CHECK(b.average_auto);
  CHECK(b.window_samples == 2001);
  REQUIRE(b.block_slips.size() == 2);
  CHECK(b.block_slips[1].onset == 1.48e-3);
  CHECK(b.block_slips[1].end == 1.5e-3);
  CHECK(b.block_slips[1].drop == 2.25e-4);
  CHECK(b.F_f_spread == 0.125);
  REQUIRE(b.regime);
  CHECK(b.regime->kind == Regime::stick_slip);
  CHECK(b.regime->drift == 0.015);
  CHECK(b.regime->trend_share == 0.02);
  CHECK(j["regime"]["mu_trusted"] == true);
  CHECK(mu_warning(b).empty());
  CHECK(j["regime"]["fix"].is_null());
  b.regime->kind = Regime::unsettled;
  CHECK_THAT(mu_warning(b), Catch::StartsWith("mu is not a friction coefficient yet: the "
                                              "averaging window [0.001, 0.003] s holds no whole "
                                              "cycle"));
  CHECK_THAT(to_json(b)["regime"]["fix"].get<std::string>(), Catch::StartsWith("a longer window"));
  CHECK(b.F_N == a.F_N);
  CHECK(b.contacts == 2);
  CHECK(b.t_end == a.t_end);
  CHECK(b.average_from == a.average_from);
  CHECK(b.wall_seconds == a.wall_seconds);
  CHECK(b.energy_residual == a.energy_residual);
  CHECK(b.energy_audit_bound == a.energy_audit_bound);
  CHECK(b.steady_sliding_mu == a.steady_sliding_mu);
  CHECK(b.solver == a.solver);
  CHECK(b.solver_stats.steps == 12197);
  CHECK(b.solver_stats.rhs_implicit == 74181);
  CHECK(b.solver_stats.last_step == 1.7e-7);
  CHECK(b.git_commit == "abc123");
  CHECK(b.sundials_version == "6.4.1");
  CHECK(b.case_json == a.case_json);
  REQUIRE(b.events);
  CHECK(b.events->count == 50);
  CHECK(b.events->window_from == 1e-3);
  CHECK(b.events->window_to == 3e-3);
  REQUIRE(b.events->per_contact.size() == 2);
  CHECK(b.events->per_contact[0].slips == 14);
  CHECK(b.events->per_contact[0].mean_recurrence == 2.8e-4);
  CHECK(b.events->per_contact[0].slipping_fraction == 0.18);
  CHECK(b.events->per_contact[1].contact == 1);
  CHECK(std::isnan(b.events->per_contact[1].mean_recurrence));
  CHECK(std::isnan(b.events->per_contact[1].mean_slip_duration));
  REQUIRE(b.synchronization);
  CHECK(b.synchronization->contact_b == 1);
  CHECK(b.synchronization->lag_max == 1.1e-5);
  CHECK(b.synchronization->coincident_fraction == 1.0);
  CHECK_FALSE(b.synchronization->xcorr_peak);
  CHECK(b.synchronization->xcorr_lag == 8e-6);
}

TEST_CASE("an older summary without the newer fields reads with them empty", "[summary]") {
  nlohmann::json j = to_json(full_summary());
  j.erase("mu_whole_cycles");
  j.erase("F_f_spread");
  j.erase("regime");
  j.erase("events");
  j.erase("synchronization");
  const Summary s = summary_from_json(j);
  CHECK_FALSE(s.mu_whole_cycles);
  CHECK_FALSE(s.F_f_spread);
  CHECK_FALSE(s.regime);
  CHECK(mu_warning(s).empty());  // an older run's window was never judged
  CHECK_FALSE(s.events);
  CHECK_FALSE(s.synchronization);
  CHECK(s.mu == 5.25);
  // The coincidence window was "window" before it was named apart from events.window.
  nlohmann::json renamed = to_json(full_summary());
  auto& sync = renamed["synchronization"];
  sync["window"] = sync["coincidence_window"];
  sync.erase("coincidence_window");
  CHECK(summary_from_json(renamed).synchronization->window == 1.2e-5);
}

TEST_CASE("a summary with a field missing or of the wrong type names it", "[summary]") {
  const nlohmann::json good = to_json(full_summary());
  auto message = [](const nlohmann::json& j) {
    try {
      summary_from_json(j);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto without = [&](const char* key) {
    nlohmann::json j = good;
    j.erase(key);
    return j;
  };
  CHECK(message(without("energy_residual")) == "no \"energy_residual\"");
  CHECK(message(without("case")) == "no \"case\"");
  nlohmann::json j = good;
  j["theta"] = "half";
  CHECK(message(j) == "\"theta\" is not a number");
  j = good;
  j["provenance"].erase("git_commit");
  CHECK(message(j) == "provenance: no \"git_commit\"");
  j = good;
  j["synchronization"].erase("lag_mean");
  CHECK(message(j) == "synchronization: no \"lag_mean\"");
  j = good;
  j["mu_whole_cycles"]["block_slips"] = "7";
  CHECK(message(j) == "mu_whole_cycles: \"block_slips\" is not a number");
  j = good;
  j["block_slips"][0].erase("drop");
  CHECK(message(j) == "block_slips: no \"drop\"");
}

TEST_CASE("an undersampled window's fix: a finer interval, or a longer window", "[summary]") {
  Summary s = full_summary();
  s.mu_whole_cycles.reset();
  s.regime = WindowRegime{Regime::undersampled, 0.0, 0.0};
  s.window_samples = 3;
  s.case_json = {{"output", {{"interval", 1e-3}}}};
  // [1, 3] ms at 1e-3 s: fewer than ten intervals fit, a finer interval alone would do.
  CHECK_THAT(regime_fix(s), Catch::StartsWith("a longer window (run.t_end) or a finer "
                                              "output.interval: the window is shorter than 10"));
  s.case_json = {{"output", {{"interval", 1e-5}}}};
  CHECK_THAT(regime_fix(s),
             Catch::StartsWith("a finer output.interval: the window holds 3 samples of F_f"));
}

TEST_CASE("read_summary: none, cut short, not a summary, and a written one", "[summary]") {
  const test::TempDir tmp("stickslip_test_summary");
  const fs::path& dir = tmp.path;
  CHECK_FALSE(read_summary(dir));  // no file
  std::ofstream(dir / "summary.json") << R"({"mu": 5.2, "theta")";
  CHECK_FALSE(read_summary(dir));  // cut short: not finished
  std::ofstream(dir / "summary.json") << R"({"mu": 5.2})";
  CHECK_THROWS_WITH(read_summary(dir),
                    Catch::Contains("summary.json: not a run summary: no \"theta\""));
  write_summary(dir, full_summary());
  const auto s = read_summary(dir);
  REQUIRE(s);
  CHECK(s->mu == 5.25);
}

TEST_CASE("a summary warns of a mu from the loading and of an rtol too loose for slip times",
          "[summary]") {
  Summary s = full_summary();
  CHECK(summary_warnings(s, 1e-6).empty());  // whole cycles, the default rtol
  CHECK(summary_warnings(s, kLooseRtol).empty());
  s.regime = WindowRegime{Regime::loading, 0.66, 0.9999};
  s.warnings = summary_warnings(s, 1e-4);
  REQUIRE(s.warnings.size() == 2);
  CHECK(s.warnings[0].about == "mu");
  CHECK_THAT(s.warnings[0].text, Catch::Contains("rises as a ramp (by 66 %)"));
  CHECK(s.warnings[1].about == "rtol");
  CHECK_THAT(s.warnings[1].text, Catch::StartsWith("rtol = 0.0001 is looser than 1e-05"));
  // They read back from summary.json; a summary without them has none.
  const Summary back = summary_from_json(nlohmann::json::parse(to_json(s).dump()));
  REQUIRE(back.warnings.size() == 2);
  CHECK(back.warnings[1].text == s.warnings[1].text);
  nlohmann::json older = to_json(s);
  older.erase("warnings");
  CHECK(summary_from_json(older).warnings.empty());
}
