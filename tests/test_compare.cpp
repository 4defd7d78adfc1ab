// `stickslip compare` on output directories written by hand (no simulation):
// the differences it reports, the tolerance rule, bad input, and the command
// line's exit codes.
#include <sys/wait.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "stickslip/analysis/compare.hpp"
#include "stickslip/output/summary.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace stickslip;
using Catch::Contains;
using Catch::StartsWith;

namespace {

void spit(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string fmt(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

using test::TempDir;

// A run's summary.json with the fields compare reads; the rest as a run that
// did nothing would have them.
nlohmann::json summary_json(double mu, double t_end = 5e-3) {
  Summary s;
  s.mu = mu;
  s.t_end = t_end;
  s.average_from = 1e-3;
  s.case_json = {{"run", {{"t_end", t_end}, {"average_from", 1e-3}}}};
  return to_json(s);
}

void write_summary(const fs::path& dir, double mu, double t_end = 5e-3) {
  fs::create_directories(dir);
  spit(dir / "summary.json", summary_json(mu, t_end).dump(2));
}

// traces.csv with columns vx_0, vy_0 sampled from f0, f1 at t = t0, t0 + dt, … (n rows).
void write_traces(const fs::path& dir, double t0, double dt, int n,
                  const std::function<double(double)>& f0,
                  const std::function<double(double)>& f1) {
  std::string text = "t,vx_0,vy_0\n";
  for (int i = 0; i < n; ++i) {
    const double t = t0 + i * dt;
    text += fmt(t) + "," + fmt(f0(t)) + "," + fmt(f1(t)) + "\n";
  }
  spit(dir / "traces.csv", text);
}

struct Ev {
  double t;
  int contact;
  const char* kind;
};

void write_events(const fs::path& dir, const std::vector<Ev>& events) {
  std::string text = "t,contact,kind,speed,force\n";
  for (const Ev& e : events)
    text += fmt(e.t) + "," + std::to_string(e.contact) + "," + e.kind + ",4.75e-4,1.2e-3\n";
  spit(dir / "events.csv", text);
}

// Two contacts stick-slipping over 5 ms.
std::vector<Ev> base_events() {
  return {{7.0e-4, 0, "slip"}, {7.03e-4, 0, "stick"}, {9.0e-4, 1, "slip"},  {9.02e-4, 1, "stick"},
          {9.9e-4, 0, "slip"}, {9.93e-4, 0, "stick"}, {1.27e-3, 0, "slip"}, {1.273e-3, 0, "stick"}};
}

// A complete run directory: summary, traces, events.
void write_run(const fs::path& dir, double mu, const std::vector<Ev>& events) {
  write_summary(dir, mu);
  write_traces(
      dir, 0.0, 1e-6, 201, [](double t) { return 1e-3 + 0.1 * std::sin(3e4 * t); },
      [](double t) { return 1e-5 * std::cos(2e4 * t); });
  write_events(dir, events);
}

const TraceDiff& column(const CompareResult& r, const std::string& name) {
  for (const TraceDiff& d : r.traces)
    if (d.column == name) return d;
  FAIL("no column " << name);
  throw;
}

const EventDiff& group(const CompareResult& r, int contact, EventKind kind) {
  for (const EventDiff& d : r.events)
    if (d.contact == contact && d.kind == kind) return d;
  FAIL("no event group for contact " << contact);
  throw;
}

}  // namespace

TEST_CASE("compare: identical runs differ by nothing and pass", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4321, base_events());
  fs::copy(tmp.path / "a", tmp.path / "b");

  const CompareResult r = compare_runs(tmp.path / "a", tmp.path / "b", 1e-2);
  CHECK(r.mu_a == 0.4321);
  CHECK(r.mu_b == 0.4321);
  CHECK(r.mu_rel_diff == 0.0);
  CHECK(r.t_end_a == 5e-3);
  CHECK(r.event_tolerance == Approx(5e-5).epsilon(1e-15));
  CHECK(r.traces_a);
  CHECK(r.traces_b);
  REQUIRE(r.traces.size() == 2);
  for (const TraceDiff& d : r.traces) {
    INFO(d.column);
    CHECK(d.samples == 201);
    CHECK(d.l2 == 0.0);
    CHECK(d.max_abs == 0.0);
    CHECK(d.rel_l2 == 0.0);
  }
  CHECK(r.events_a);
  CHECK(r.events_b);
  REQUIRE(r.events.size() == 4);  // contacts 0 and 1, slip and stick each
  CHECK(group(r, 0, EventKind::slip).matched == 3);
  CHECK(group(r, 1, EventKind::stick).matched == 1);
  for (const EventDiff& d : r.events) {
    CHECK(d.max_dt == 0.0);
    CHECK(d.mean_dt == 0.0);
    CHECK(d.unmatched_a == 0);
    CHECK(d.unmatched_b == 0);
  }
  CHECK(r.failures.empty());
  CHECK(r.pass());

  // The command: exit 0, a report, and the JSON in B by default.
  std::ostringstream out, err;
  CHECK(compare_command(tmp.path / "a", tmp.path / "b", 1e-2, {}, out, err) == 0);
  CHECK(err.str().empty());
  CHECK_THAT(out.str(), Contains("PASS"));
  const auto j = nlohmann::json::parse(slurp(tmp.path / "b" / "compare.json"));
  CHECK(j["pass"] == true);
  CHECK(j["mu"]["rel_diff"] == 0.0);
  CHECK(j["traces"]["columns"].size() == 2);
  CHECK(j["events"]["groups"].size() == 4);
  CHECK(j["failures"].empty());
}

TEST_CASE("compare: mu 5 % apart fails at rtol 1e-2 and passes at 0.1", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4, base_events());
  write_run(tmp.path / "b", 0.42, base_events());

  const CompareResult tight = compare_runs(tmp.path / "a", tmp.path / "b", 1e-2);
  CHECK(tight.mu_rel_diff == Approx(0.05).epsilon(1e-12));
  CHECK_FALSE(tight.pass());
  REQUIRE(tight.failures.size() == 1);
  CHECK_THAT(tight.failures[0], StartsWith("mu:"));

  const CompareResult loose = compare_runs(tmp.path / "a", tmp.path / "b", 0.1);
  CHECK(loose.mu_rel_diff == Approx(0.05).epsilon(1e-12));
  CHECK(loose.pass());

  std::ostringstream out, err;
  const fs::path report = tmp.path / "report.json";
  CHECK(compare_command(tmp.path / "a", tmp.path / "b", 1e-2, report, out, err) == 1);
  CHECK_THAT(out.str(), Contains("FAIL"));
  CHECK(nlohmann::json::parse(slurp(report))["pass"] == false);
  CHECK_FALSE(fs::exists(tmp.path / "b" / "compare.json"));  // --out was given
  CHECK(compare_command(tmp.path / "a", tmp.path / "b", 0.1, report, out, err) == 0);
}

TEST_CASE("compare: a shifted event gives its time difference", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4, base_events());
  auto shifted = base_events();
  shifted[4].t += 2e-5;  // contact 0's second slip, 20 µs late
  write_run(tmp.path / "b", 0.4, shifted);

  const CompareResult r = compare_runs(tmp.path / "a", tmp.path / "b", 1e-2);
  const EventDiff& slips = group(r, 0, EventKind::slip);
  CHECK(slips.matched == 3);
  CHECK(slips.max_dt == Approx(2e-5).epsilon(1e-9));
  CHECK(slips.mean_dt == Approx(2e-5 / 3).epsilon(1e-9));
  CHECK(slips.unmatched_a == 0);
  CHECK(slips.unmatched_b == 0);
  CHECK(group(r, 0, EventKind::stick).max_dt == 0.0);
  CHECK(group(r, 1, EventKind::slip).max_dt == 0.0);
  // 20 µs is within rtol × t_end = 1e-2 × 5 ms = 50 µs …
  CHECK(r.pass());
  // … but not within 1e-3 × 5 ms = 5 µs.
  const CompareResult tight = compare_runs(tmp.path / "a", tmp.path / "b", 1e-3);
  REQUIRE(tight.failures.size() == 1);
  CHECK_THAT(tight.failures[0], Contains("contact 0 slip"));
}

TEST_CASE("compare: an extra event is unmatched and fails at any tolerance", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4, base_events());
  auto extra = base_events();
  extra.push_back({1.5e-3, 1, "slip"});
  write_run(tmp.path / "b", 0.4, extra);

  const CompareResult r = compare_runs(tmp.path / "a", tmp.path / "b", 0.5);
  const EventDiff& d = group(r, 1, EventKind::slip);
  CHECK(d.matched == 1);
  CHECK(d.unmatched_a == 0);
  CHECK(d.unmatched_b == 1);
  CHECK(d.max_dt == 0.0);
  CHECK(group(r, 1, EventKind::stick).unmatched_b == 0);
  REQUIRE(r.failures.size() == 1);
  CHECK_THAT(r.failures[0], Contains("without partner"));

  // The other way round the extra event is A's; a kind that only one run has
  // is a group with nothing matched.
  const CompareResult back = compare_runs(tmp.path / "b", tmp.path / "a", 0.5);
  CHECK(group(back, 1, EventKind::slip).unmatched_a == 1);
  write_events(tmp.path / "b", {{1e-3, 2, "stick"}});
  write_events(tmp.path / "a", {});
  const CompareResult lone = compare_runs(tmp.path / "a", tmp.path / "b", 0.5);
  REQUIRE(lone.events.size() == 1);
  CHECK(lone.events[0].matched == 0);
  CHECK(std::isnan(lone.events[0].max_dt));
  CHECK(lone.events[0].unmatched_b == 1);
  CHECK_FALSE(lone.pass());
}

TEST_CASE("compare: traces on different grids are interpolated linearly onto A's", "[compare]") {
  TempDir tmp;
  const fs::path a = tmp.path / "a", b = tmp.path / "b";
  write_summary(a, 0.4);
  write_summary(b, 0.4);

  SECTION("a linear signal interpolates exactly") {
    auto line = [](double t) { return 3e-3 + 20.0 * t; };
    auto flat = [](double) { return 0.0; };
    write_traces(a, 0.0, 1e-6, 101, line, flat);     // 0 … 100 µs
    write_traces(b, 2e-6, 0.7e-6, 200, line, flat);  // 2 … 141.3 µs, off A's grid
    const CompareResult r = compare_runs(a, b, 1e-2);
    const TraceDiff& vx = column(r, "vx_0");
    CHECK(vx.samples == 99);  // A's times in the overlap [2, 100] µs
    CHECK(vx.l2 == Approx(0.0).margin(1e-15));
    CHECK(vx.max_abs == Approx(0.0).margin(1e-15));
    CHECK(vx.rel_l2 == Approx(0.0).margin(1e-12));
    const TraceDiff& vy = column(r, "vy_0");  // zero in both: no relative difference
    CHECK(vy.rel_l2 == 0.0);
    CHECK(r.pass());
  }

  SECTION("B interpolated at the midpoints of its grid: the known chord error of t²") {
    // B sampled every 2 µs, A at the odd µs between: the chord of (t/µs)² over
    // [2j, 2j+2] exceeds the curve at the midpoint by exactly 1.
    auto square = [](double t) { return (t / 1e-6) * (t / 1e-6); };
    auto zero = [](double) { return 0.0; };
    write_traces(a, 1e-6, 2e-6, 50, square, zero);  // 1, 3, …, 99 µs
    write_traces(b, 0.0, 2e-6, 51, square, zero);   // 0, 2, …, 100 µs
    const CompareResult r = compare_runs(a, b, 1e-2);
    const TraceDiff& vx = column(r, "vx_0");
    CHECK(vx.samples == 50);
    CHECK(vx.l2 == Approx(1.0).epsilon(1e-8));
    CHECK(vx.max_abs == Approx(1.0).epsilon(1e-8));
    double sum = 0.0;
    for (int j = 0; j < 50; ++j) sum += std::pow(2.0 * j + 1.0, 4);
    CHECK(vx.rel_l2 == Approx(1.0 / std::sqrt(sum / 50)).epsilon(1e-8));
  }

  SECTION("an offset shows as L2 and max difference, and fails beyond rtol") {
    auto base = [](double t) { return 1.0 + std::sin(1e5 * t); };
    auto shifted = [](double t) { return 1.05 + std::sin(1e5 * t); };
    auto zero = [](double) { return 0.0; };
    write_traces(a, 0.0, 1e-6, 101, base, zero);
    write_traces(b, 0.0, 0.5e-6, 201, shifted, zero);
    const CompareResult r = compare_runs(a, b, 1e-2);
    const TraceDiff& vx = column(r, "vx_0");
    CHECK(vx.samples == 101);
    // B's chords of the sine are off by at most h²/8·max|f''| = 3.1e-4 here.
    CHECK(vx.max_abs == Approx(0.05).margin(4e-4));
    CHECK(vx.l2 == Approx(0.05).margin(4e-4));
    CHECK(vx.rel_l2 > 1e-2);
    REQUIRE(r.failures.size() == 1);
    CHECK_THAT(r.failures[0], Contains("vx_0"));
    CHECK(compare_runs(a, b, 0.1).pass());
  }

  SECTION("no common times fails; columns in one run only are listed, not compared") {
    auto one = [](double) { return 1.0; };
    write_traces(a, 0.0, 1e-6, 10, one, one);
    spit(b / "traces.csv", "t,vx_0,vx_5\n1e-3,1,2\n2e-3,1,2\n");
    const CompareResult r = compare_runs(a, b, 1e-2);
    REQUIRE(r.traces.size() == 1);
    CHECK(r.traces[0].samples == 0);
    CHECK(r.columns_only_a == std::vector<std::string>{"vy_0"});
    CHECK(r.columns_only_b == std::vector<std::string>{"vx_5"});
    REQUIRE(r.failures.size() == 1);
    CHECK_THAT(r.failures[0], Contains("no common times"));
  }
}

TEST_CASE("compare: files present in only one run are reported, not compared", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4, base_events());
  write_summary(tmp.path / "b", 0.4);
  const CompareResult r = compare_runs(tmp.path / "a", tmp.path / "b", 1e-2);
  CHECK(r.traces_a);
  CHECK_FALSE(r.traces_b);
  CHECK(r.traces.empty());
  CHECK(r.events_a);
  CHECK_FALSE(r.events_b);
  CHECK(r.events.empty());
  CHECK(r.pass());
  std::ostringstream out;
  print_report(out, r);
  CHECK_THAT(out.str(), Contains("traces table only in A"));
  CHECK_THAT(out.str(), Contains("events table only in A"));
}

TEST_CASE("compare: bad input is a CompareError, exit code 2, one line naming the file",
          "[compare]") {
  TempDir tmp;
  const fs::path a = tmp.path / "a", b = tmp.path / "b";
  write_run(a, 0.4, base_events());
  fs::create_directories(b);

  auto expect_bad = [&](const std::string& file_part, double rtol = 1e-2) {
    CHECK_THROWS_AS(compare_runs(a, b, rtol), CompareError);
    std::ostringstream out, err;
    CHECK(compare_command(a, b, rtol, {}, out, err) == 2);
    CHECK_THAT(err.str(), StartsWith("error: "));
    CHECK_THAT(err.str(), Contains(file_part));
    const std::string message = err.str();
    CHECK(std::count(message.begin(), message.end(), '\n') == 1);
    CHECK_FALSE(fs::exists(b / "compare.json"));
  };

  SECTION("missing summary") {
    expect_bad((b / "summary.json").string());
  }
  SECTION("missing directory") {
    fs::remove_all(b);
    expect_bad(b.string());
  }
  SECTION("summary without mu") {
    auto j = summary_json(0.4);
    j.erase("mu");
    spit(b / "summary.json", j.dump());
    expect_bad("summary.json: not a run summary: no \"mu\"");
  }
  SECTION("summary without t_end") {
    auto j = summary_json(0.4);
    j.erase("t_end");
    spit(b / "summary.json", j.dump());
    expect_bad("no \"t_end\"");
  }
  SECTION("summary with a malformed events block") {
    auto j = summary_json(0.4);
    j["events"] = {{"count", 2}, {"window", {1e-3, 5e-3}}, {"per_contact", {{{"contact", 0}}}}};
    spit(b / "summary.json", j.dump());
    expect_bad("events: no \"slips\"");
  }
  SECTION("summary not JSON") {
    spit(b / "summary.json", "mu = 0.4\n");
    expect_bad("summary.json");
  }
  SECTION("a trace value that is not a number") {
    write_run(b, 0.4, base_events());
    spit(b / "traces.csv", "t,vx_0,vy_0\n0,1,2\n1e-6,1,x2\n");
    expect_bad("traces.csv: line 3");
  }
  SECTION("a short trace row") {
    write_run(b, 0.4, base_events());
    spit(b / "traces.csv", "t,vx_0,vy_0\n0,1,2\n1e-6,1\n");
    expect_bad("traces.csv: line 3");
  }
  SECTION("trace times not increasing") {
    write_run(b, 0.4, base_events());
    spit(b / "traces.csv", "t,vx_0,vy_0\n0,1,2\n0,1,2\n");
    expect_bad("traces.csv: line 3");
  }
  SECTION("an event of unknown kind") {
    write_run(b, 0.4, base_events());
    spit(b / "events.csv", "t,contact,kind,speed,force\n1e-3,0,slide,1,1\n");
    expect_bad("events.csv: line 2");
  }
  SECTION("an events file without its header") {
    write_run(b, 0.4, base_events());
    spit(b / "events.csv", "");
    expect_bad("events.csv");
  }
  SECTION("a negative tolerance") {
    write_run(b, 0.4, base_events());
    expect_bad("rtol", -1e-2);
  }
}

// The command line itself: the subcommand's wiring in main and its exit codes.
TEST_CASE("compare: the stickslip compare command", "[compare]") {
  TempDir tmp;
  write_run(tmp.path / "a", 0.4, base_events());
  write_run(tmp.path / "b", 0.42, base_events());
  auto run = [&](const std::string& args) {
    const std::string cmd = std::string("'") + STICKSLIP_EXE + "' compare " + args + " >'" +
                            (tmp.path / "stdout").string() + "' 2>'" +
                            (tmp.path / "stderr").string() + "'";
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  };
  const std::string a = "'" + (tmp.path / "a").string() + "'";
  const std::string b = "'" + (tmp.path / "b").string() + "'";

  CHECK(run(a + " " + b) == 1);  // default rtol 1e-2 < 5 %
  CHECK_THAT(slurp(tmp.path / "stdout"), Contains("FAIL"));
  CHECK(fs::exists(tmp.path / "b" / "compare.json"));

  const fs::path out = tmp.path / "c.json";
  CHECK(run(a + " " + b + " --rtol 0.1 --out '" + out.string() + "'") == 0);
  CHECK(nlohmann::json::parse(slurp(out))["rtol"] == 0.1);

  CHECK(run(a + " '" + (tmp.path / "nowhere").string() + "'") == 2);
  const std::string err = slurp(tmp.path / "stderr");
  CHECK_THAT(err, StartsWith("error: "));
  CHECK_THAT(err, Contains("nowhere"));

  CHECK(run(a) == 2);  // DIR_B missing: a usage error
}
