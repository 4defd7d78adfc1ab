// The case-file reader: values, defaults, and the one-line error messages
// (file:line: section.key: what), including those blamed on --set.

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "stickslip/case/reader.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "temp_dir.hpp"

using namespace stickslip;
using Catch::Contains;

namespace {

Case parse(const std::string& text, const std::vector<std::string>& overrides = {}) {
  return parse_case(text, "cases/t.toml", overrides);
}

}  // namespace

TEST_CASE("an empty case file gives the defaults", "[case]") {
  const Case c = parse("");
  const Case d;
  CHECK(c.source == "cases/t.toml");
  CHECK(c.lattice.nx == d.lattice.nx);
  CHECK(c.lattice.nz == d.lattice.nz);
  CHECK(c.material.poisson_ratio == d.material.poisson_ratio);
  CHECK(c.material.grad_div == GradDiv::paper);
  CHECK(c.interface.coverage == d.interface.coverage);
  CHECK(c.interface.seed == d.interface.seed);
  CHECK(c.interface.contacts.empty());
  CHECK(c.drive.velocity == d.drive.velocity);
  CHECK(c.run.initial == InitialState::rest);
  CHECK(c.solver.max_steps == d.solver.max_steps);
  CHECK(c.output.dir.empty());
  CHECK(c.output.traces == ContactSelection::none);
}

TEST_CASE("absolute tolerances are unset unless given, in a case file as in C++", "[case]") {
  // Unset (0) means "from rtol by the rule" (integrate/tolerances.hpp), so a
  // Case built in C++ and one read from a file get the same tolerances.
  const Case c = parse("[drive]\nvelocity = 1e-6");
  CHECK(c.solver.atol_velocity == Case{}.solver.atol_velocity);
  CHECK(c.solver.atol_displacement == Case{}.solver.atol_displacement);
  CHECK(c.solver.atol_velocity == 0.0);
  CHECK(parse("[solver]\natol_velocity = 3e-9").solver.atol_velocity == 3e-9);
  // An unset tolerance is absent from the resolved case, so a summary.json
  // reads back as the same case.
  CHECK_FALSE(to_json(c)["solver"].contains("atol_velocity"));
  CHECK(to_json(parse("[solver]\natol_velocity = 3e-9"))["solver"]["atol_velocity"] == 3e-9);
}

TEST_CASE("every key is read into its field", "[case]") {
  const Case c = parse(R"(
[lattice]
nx = 4
ny = 5
nz = 3
spacing = 2e-4
[material]
density = 2000
youngs_modulus = 3e7
poisson_ratio = 0.25
grad_div = "navier"
[damping]
bulk = 0.2
contact = 0
[interface]
coverage = 0.5
seed = 42
shear_stress = 1e6
shape = 0.3
v_m = 2e-3
spread = 0
epsilon = 0.05
max_pressure = 2e6
slip_threshold = 2
[drive]
velocity = 1
[run]
t_end = 0.01
average_from = 0.002
initial = "sliding"
[solver]
method = "imex"
rtol = 1e-5
atol_displacement = 1e-11
atol_velocity = 1e-8
max_steps = 1000
audit_bound = 1e-3
[output]
dir = "out/x"
interval = 2e-6
traces = "all"
)");
  CHECK(c.lattice.nx == 4);
  CHECK(c.lattice.ny == 5);
  CHECK(c.lattice.nz == 3);
  CHECK(c.lattice.spacing == 2e-4);
  CHECK(c.material.density == 2000.0);  // a TOML integer for a float key
  CHECK(c.material.youngs_modulus == 3e7);
  CHECK(c.material.poisson_ratio == 0.25);
  CHECK(c.material.grad_div == GradDiv::navier);
  CHECK(c.damping.bulk == 0.2);
  CHECK(c.damping.contact == 0.0);
  CHECK(c.interface.coverage == 0.5);
  CHECK(c.interface.seed == 42u);
  CHECK(c.interface.shear_stress == 1e6);
  CHECK(c.interface.shape == 0.3);
  CHECK(c.interface.v_m == 2e-3);
  CHECK(c.interface.spread == 0.0);
  CHECK(c.interface.epsilon == 0.05);
  CHECK(c.interface.max_pressure == 2e6);
  CHECK(c.interface.slip_threshold == 2.0);
  CHECK(c.drive.velocity == 1.0);
  CHECK(c.run.t_end == 0.01);
  CHECK(c.run.average_from == 0.002);
  CHECK(c.run.initial == InitialState::sliding);
  CHECK(c.solver.method == Method::imex);
  CHECK(c.solver.rtol == 1e-5);
  CHECK(c.solver.atol_displacement == 1e-11);
  CHECK(c.solver.atol_velocity == 1e-8);
  CHECK(c.solver.max_steps == 1000);
  CHECK(c.solver.audit_bound == 1e-3);
  CHECK(c.output.dir == std::filesystem::path("cases/out/x"));  // relative to the case file
  CHECK(c.output.interval == 2e-6);
  CHECK(c.output.traces == ContactSelection::all);
}

TEST_CASE("output.dir: absolute paths are kept", "[case]") {
  CHECK(parse("[output]\ndir = \"/tmp/run\"").output.dir == std::filesystem::path("/tmp/run"));
}

TEST_CASE("output.dir is relative to where it was written: the case file, or the command line",
          "[case]") {
  // In the file: next to the file. With --set: the working directory, as --out
  // (it was next to the case file, so --set output.dir=x and --out x differed).
  CHECK(parse("[output]\ndir = \"x\"\n").output.dir == std::filesystem::path("cases/x"));
  CHECK(parse("", {"output.dir=\"x\""}).output.dir == std::filesystem::path("x"));
  CHECK(parse("[output]\ndir = \"y\"\n", {" output.dir = \"x\""}).output.dir ==
        std::filesystem::path("x"));
  REQUIRE_THROWS_WITH(parse("", {"output.dir=\"\""}),
                      Catch::Contains("output.dir: must not be empty"));
}

TEST_CASE("malformed TOML names the file and line", "[case]") {
  REQUIRE_THROWS_AS(parse("[lattice]\nnx = 3\nny = = 4\n"), CaseError);
  REQUIRE_THROWS_WITH(parse("[lattice]\nnx = 3\nny = = 4\n"),
                      Catch::StartsWith("cases/t.toml:3: malformed TOML: "));
  REQUIRE_THROWS_WITH(parse("[drive]\nvelocity = 1\n\nvelocity = 2\n"),
                      Catch::StartsWith("cases/t.toml:4: malformed TOML: "));
}

TEST_CASE("a case file as Windows editors write it (byte-order mark, CRLF) reads as its text",
          "[case]") {
  const std::string plain = "[lattice]\nnx = 4\n\n[drive]\nvelocity = 2e-3  # m/s\n";
  std::string windows = "\xEF\xBB\xBF";
  for (const char ch : plain) windows += ch == '\n' ? std::string("\r\n") : std::string(1, ch);
  CHECK(to_json(parse(windows)) == to_json(parse(plain)));
  CHECK(parse(windows).lattice.nx == 4);
  // Errors keep their lines, the mark counted in none.
  REQUIRE_THROWS_WITH(parse("\xEF\xBB\xBF[drive]\r\n\r\nvelocty = 1e-3\r\n"),
                      Catch::StartsWith("cases/t.toml:3: drive.velocty: unknown key"));
}

TEST_CASE("unknown keys and sections, with a suggestion when close", "[case]") {
  REQUIRE_THROWS_WITH(
      parse("[drive]\n\nvelocty = 1e-3\n"),
      "cases/t.toml:3: drive.velocty: unknown key 'velocty' (did you mean 'velocity'?)");
  REQUIRE_THROWS_WITH(parse("[lattic]\nnx = 3\n"),
                      "cases/t.toml:1: lattic: unknown section 'lattic' (did you mean 'lattice'?)");
  // Nothing close: list the valid keys instead of guessing.
  REQUIRE_THROWS_WITH(
      parse("[drive]\nfrobnicate = 1\n"),
      "cases/t.toml:2: drive.frobnicate: unknown key 'frobnicate' (valid: velocity)");
  REQUIRE_THROWS_WITH(parse("title = \"x\"\n"),
                      Contains("cases/t.toml:1: title: unknown section 'title'"));
  REQUIRE_THROWS_WITH(parse("lattice = 3\n"),
                      "cases/t.toml:1: lattice: expected a table [lattice], got integer");
}

TEST_CASE("messages stay on one line", "[case]") {
  REQUIRE_THROWS_WITH(
      parse("[drive]\n\"velo\\ncity\" = 1\n"),
      "cases/t.toml:2: drive.velo\\x0acity: unknown key 'velo\\x0acity' (did you mean "
      "'velocity'?)");
}

TEST_CASE("wrong types", "[case]") {
  REQUIRE_THROWS_WITH(parse("[run]\nt_end = \"soon\"\n"),
                      "cases/t.toml:2: run.t_end: expected a number, got string");
  REQUIRE_THROWS_WITH(parse("[lattice]\n\nnx = 3.0\n"),
                      "cases/t.toml:3: lattice.nx: expected an integer, got floating-point");
  REQUIRE_THROWS_WITH(parse("[solver]\nmax_steps = 1e6\n"),
                      "cases/t.toml:2: solver.max_steps: expected an integer, got floating-point");
  REQUIRE_THROWS_WITH(parse("[material]\ngrad_div = 1\n"),
                      "cases/t.toml:2: material.grad_div: expected a string, got integer");
  REQUIRE_THROWS_WITH(
      parse("[material]\ngrad_div = \"lame\"\n"),
      "cases/t.toml:2: material.grad_div: must be one of \"paper\", \"navier\", got \"lame\"");
  REQUIRE_THROWS_WITH(parse("[run]\nt_end = inf\n"),
                      "cases/t.toml:2: run.t_end: must be finite, got inf");
}

TEST_CASE("out-of-range values name the range and the value", "[case]") {
  auto [text, message] = GENERATE(table<std::string, std::string>({
      {"[lattice]\nnx = 0", "cases/t.toml:2: lattice.nx: must be >= 1, got 0"},
      {"[lattice]\nny = -3", "cases/t.toml:2: lattice.ny: must be >= 1, got -3"},
      {"[lattice]\nnz = 1", "cases/t.toml:2: lattice.nz: must be >= 2, got 1"},
      {"[lattice]\nnx = 3000000000",
       "cases/t.toml:2: lattice.nx: must be <= 2147483647, got 3000000000"},
      {"[lattice]\nspacing = 0", "cases/t.toml:2: lattice.spacing: must be > 0, got 0"},
      {"[material]\ndensity = -1", "cases/t.toml:2: material.density: must be > 0, got -1"},
      {"[material]\npoisson_ratio = 0.6",
       "cases/t.toml:2: material.poisson_ratio: must be in (-1, 0.5], got 0.6"},
      {"[material]\npoisson_ratio = -1",
       "cases/t.toml:2: material.poisson_ratio: must be in (-1, 0.5], got -1"},
      {"[damping]\nbulk = -0.1", "cases/t.toml:2: damping.bulk: must be >= 0, got -0.1"},
      {"[interface]\ncoverage = 1.5",
       "cases/t.toml:2: interface.coverage: must be in (0, 1], got 1.5"},
      {"[interface]\ncoverage = 0", "cases/t.toml:2: interface.coverage: must be in (0, 1], got 0"},
      {"[interface]\nseed = -1", "cases/t.toml:2: interface.seed: must be >= 0, got -1"},
      {"[interface]\nspread = -0.5", "cases/t.toml:2: interface.spread: must be >= 0, got -0.5"},
      {"[interface]\nslip_threshold = 0",
       "cases/t.toml:2: interface.slip_threshold: must be > 0, got 0"},
      {"[drive]\nvelocity = -1e-3", "cases/t.toml:2: drive.velocity: must be >= 0, got -0.001"},
      {"[run]\nt_end = 0", "cases/t.toml:2: run.t_end: must be > 0, got 0"},
      {"[solver]\nrtol = 0", "cases/t.toml:2: solver.rtol: must be in [1e-12, 0.01], got 0"},
      {"[solver]\nmax_steps = 0", "cases/t.toml:2: solver.max_steps: must be >= 1, got 0"},
      {"[output]\ninterval = -1", "cases/t.toml:2: output.interval: must be > 0, got -1"},
  }));
  CAPTURE(text);
  REQUIRE_THROWS_WITH(parse(text), message);
}

TEST_CASE("navier needs poisson_ratio < 0.5", "[case]") {
  CHECK(parse("[material]\ngrad_div = \"navier\"\npoisson_ratio = 0.49").material.poisson_ratio ==
        0.49);
  // Blamed on poisson_ratio when the file gives it, else on grad_div.
  REQUIRE_THROWS_WITH(
      parse("[material]\ngrad_div = \"navier\"\npoisson_ratio = 0.5\n"),
      Catch::StartsWith(
          "cases/t.toml:3: material.poisson_ratio: must be < 0.5 with grad_div = \"navier\""));
  REQUIRE_THROWS_WITH(
      parse("[material]\n\ngrad_div = \"navier\"\n"),
      Catch::StartsWith("cases/t.toml:3: material.grad_div: \"navier\" needs poisson_ratio < 0.5"));
}

TEST_CASE("average_from must be before t_end", "[case]") {
  REQUIRE_THROWS_WITH(
      parse("[run]\nt_end = 1e-3\naverage_from = 1e-3\n"),
      "cases/t.toml:3: run.average_from: must be in [0, run.t_end = 0.001), got 0.001");
  // Only t_end given: the default average_from (1e-3) is not before it.
  REQUIRE_THROWS_WITH(parse("[run]\nt_end = 5e-4\n"),
                      "cases/t.toml:2: run.t_end: must be > run.average_from = 0.001, got 0.0005");
}

TEST_CASE("average_from = \"auto\" is read, written back, and nothing else is a word", "[case]") {
  const Case c = parse("[run]\nt_end = 5e-4\naverage_from = \"auto\"\n");
  CHECK(c.run.average_auto);
  CHECK(c.run.average_from == 0.0);  // any t_end is after it
  CHECK(to_json(c)["run"]["average_from"] == "auto");
  CHECK(parse(to_toml(c)).run.average_auto);
  CHECK_FALSE(parse("[run]\naverage_from = 2e-4\n").run.average_auto);
  REQUIRE_THROWS_WITH(parse("[run]\naverage_from = \"later\"\n"),
                      Catch::StartsWith("cases/t.toml:2: run.average_from: must be ") &&
                          Contains(" or \"auto\", got \"later\""));
}

TEST_CASE("a case written with its unset values spelt out is the same case", "[case]") {
  // Summaries and checkpoints written before unset values were left out carry
  // audit_bound 0, and coverage and seed beside listed contacts: still the same case.
  const Case listed = parse("[interface]\ncontacts = [{ site = [4, 2], v_star = 4.75e-4 }]\n");
  nlohmann::json older = to_json(listed);
  older["solver"]["audit_bound"] = 0.0;
  older["interface"]["coverage"] = 0.0089;
  older["interface"]["seed"] = 1;
  CHECK(same_case(older, listed));
  older["solver"]["audit_bound"] = 1e-3;  // a bound that was set is a difference
  CHECK_FALSE(same_case(older, listed));
}

TEST_CASE("coverage must give at least one contact", "[case]") {
  CHECK(parse("[lattice]\nnx = 1\nny = 1\n[interface]\ncoverage = 0.5").interface.coverage == 0.5);
  REQUIRE_THROWS_WITH(parse("[lattice]\nnx = 2\nny = 2\n[interface]\ncoverage = 0.1\n"),
                      "cases/t.toml:5: interface.coverage: a 2x2 interface at coverage 0.1 has no "
                      "contact (floor(coverage*nx*ny + 0.5) = 0)");
  REQUIRE_THROWS_WITH(parse("[lattice]\nnx = 2\nny = 2\n"),
                      Catch::StartsWith("cases/t.toml:2: lattice.nx: "));
  // Explicit contacts make coverage irrelevant.
  CHECK(parse("[lattice]\nnx = 2\nny = 2\n[interface]\ncontacts = [{site = [1, 1], v_star = 1e-4}]")
            .interface.contacts.size() == 1);
}

TEST_CASE("coverage or seed beside an explicit contacts list is refused, naming both keys",
          "[case]") {
  // They only feed the random placement: accepted, they would change nothing.
  const std::string pair =
      "[interface]\ncontacts = [{site = [1, 1], v_star = 1e-4}, {site = [5, 5], v_star = 1e-3}]\n";
  for (const char* key : {"coverage = 0.4", "seed = 3"}) {
    INFO(key);
    REQUIRE_THROWS_WITH(parse(pair + key + "\n"),
                        Catch::StartsWith("cases/t.toml:3: interface.") &&
                            Catch::Contains("interface.coverage and interface.seed, or "
                                            "interface.contacts, not both"));
  }
  REQUIRE_THROWS_WITH(parse(pair, {"interface.seed=7"}),
                      Catch::StartsWith("--set interface.seed: places contacts at random"));
  // What the case file writes back for such a case reads back (no coverage, no seed).
  const Case c = parse(pair);
  CHECK(to_json(parse(to_toml(c))) == to_json(c));
}

TEST_CASE("linear_solver = \"klu\" is refused with the reason", "[case]") {
  REQUIRE_THROWS_WITH(parse("[solver]\nmethod = \"dirk\"\nlinear_solver = \"klu\"\n"),
                      Catch::StartsWith("cases/t.toml:3: solver.linear_solver: \"klu\" is no "
                                        "longer offered") &&
                          Contains("use \"fft\""));
  CHECK(parse("[solver]\nmethod = \"bdf\"\nlinear_solver = \"fft\"\n").solver.linear_solver ==
        LinearSolver::fft);
}

TEST_CASE("[output] attempts is refused for a method whose attempts SUNDIALS keeps", "[case]") {
  // Blamed on the key given: attempts under dirk's own line, or the method
  // given after attempts by --set.
  REQUIRE_THROWS_WITH(parse("[solver]\nmethod = \"dirk\"\n[output]\nattempts = true\n"),
                      Catch::StartsWith("cases/t.toml:4: output.attempts: applies to method = "
                                        "\"multirate\" only, not \"dirk\""));
  REQUIRE_THROWS_WITH(parse("[solver]\nmethod = \"bdf\"\n[output]\nattempts = true\n"),
                      Contains("not \"bdf\""));
  CHECK(parse("[solver]\nmethod = \"multirate\"\n[output]\nattempts = true\n").output.attempts);
  // "auto" may choose multirate: allowed, and written where it does.
  CHECK(parse("[output]\nattempts = true\n").output.attempts);
}

TEST_CASE("explicit contacts are read in order, in either TOML form", "[case]") {
  const Case inline_form = parse(R"([interface]
contacts = [
  { site = [4, 7], v_star = 4.75e-4 },
  { site = [0, 0], v_star = 1 },
  { site = [14, 2], v_star = 2e-3 },
]
)");
  const auto& k = inline_form.interface.contacts;
  REQUIRE(k.size() == 3);
  CHECK((k[0].ix == 4 && k[0].iy == 7 && k[0].v_star == 4.75e-4 && k[0].line == 3));
  CHECK((k[1].ix == 0 && k[1].iy == 0 && k[1].v_star == 1.0 && k[1].line == 4));
  CHECK((k[2].ix == 14 && k[2].iy == 2 && k[2].v_star == 2e-3 && k[2].line == 5));

  const Case tables = parse(R"([[interface.contacts]]
site = [3, 1]
v_star = 1e-4
[[interface.contacts]]
site = [2, 5]
v_star = 2e-4
)");
  const auto& t = tables.interface.contacts;
  REQUIRE(t.size() == 2);
  CHECK((t[0].ix == 3 && t[0].iy == 1 && t[0].v_star == 1e-4));
  CHECK((t[1].ix == 2 && t[1].iy == 5 && t[1].v_star == 2e-4));
}

TEST_CASE("bad explicit contacts", "[case]") {
  REQUIRE_THROWS_WITH(
      parse("[lattice]\nnx = 4\n[interface]\ncontacts = [\n {site = [1, 1], v_star = 1e-4},\n "
            "{site = [4, 0], v_star = 1e-4},\n]\n"),
      "cases/t.toml:6: interface.contacts[1].site: must lie on the 4x15 interface (ix < 4, iy < "
      "15), "
      "got [4, 0]");
  REQUIRE_THROWS_WITH(parse("[interface]\ncontacts = [{site = [-1, 0], v_star = 1e-4}]\n"),
                      "cases/t.toml:2: interface.contacts[0].site: must be >= 0, got -1");
  REQUIRE_THROWS_WITH(
      parse(
          "[interface]\ncontacts = [\n {site = [4, 7], v_star = 1e-4},\n {site = [1, 1], v_star = "
          "1e-4},\n {site = [4, 7], v_star = 2e-4},\n]\n"),
      "cases/t.toml:5: interface.contacts[2].site: site [4, 7] repeats interface.contacts[0] (line "
      "3)");
  REQUIRE_THROWS_WITH(parse("[interface]\ncontacts = [{site = [1, 1], v_star = 0}]\n"),
                      "cases/t.toml:2: interface.contacts[0].v_star: must be > 0, got 0");
  REQUIRE_THROWS_WITH(
      parse("[interface]\ncontacts = [{site = [1, 1], vstar = 1e-4}]\n"),
      "cases/t.toml:2: interface.contacts[0].vstar: unknown key 'vstar' (did you mean 'v_star'?)");
  REQUIRE_THROWS_WITH(parse("[interface]\ncontacts = [{site = [1, 1, 1], v_star = 1e-4}]\n"),
                      Contains("interface.contacts[0].site: expected an array of two integers"));
  REQUIRE_THROWS_WITH(parse("[interface]\ncontacts = [{site = [1, 1]}]\n"),
                      Contains("missing v_star"));
  REQUIRE_THROWS_WITH(parse("[interface]\ncontacts = []\n"),
                      Contains("must list at least one contact"));
}

TEST_CASE("trace selection", "[case]") {
  CHECK(parse("[output]\ntraces = \"none\"").output.traces == ContactSelection::none);
  const Case c = parse("[lattice]\nnx = 10\nny = 10\n[output]\ntraces = [0, 9, 3]");  // 10 contacts
  CHECK(c.output.traces == ContactSelection::list);
  CHECK(c.output.trace_ids == std::vector<int>{0, 9, 3});

  REQUIRE_THROWS_WITH(parse("[lattice]\nnx = 10\nny = 10\n[output]\ntraces = [0,\n 10]\n"),
                      "cases/t.toml:6: output.traces[1]: must be a contact id in [0, 10), got 10");
  // With explicit contacts the count is the list's length.
  REQUIRE_THROWS_WITH(
      parse("[interface]\ncontacts = [{site = [1, 1], v_star = 1e-4}]\n[output]\ntraces = [1]\n"),
      "cases/t.toml:4: output.traces[0]: must be a contact id in [0, 1), got 1");
  REQUIRE_THROWS_WITH(parse("[output]\ntraces = [2, 5, 2]\n"),
                      "cases/t.toml:2: output.traces[2]: contact 2 repeats output.traces[0]");
  REQUIRE_THROWS_WITH(parse("[output]\ntraces = [-1]\n"),
                      "cases/t.toml:2: output.traces[0]: must be >= 0, got -1");
  REQUIRE_THROWS_WITH(parse("[output]\ntraces = \"some\"\n"),
                      "cases/t.toml:2: output.traces: must be \"all\", \"none\" or an array of "
                      "contact ids, got \"some\"");
}

TEST_CASE("overrides from --set replace or add values before validation", "[case][set]") {
  const Case c =
      parse("[drive]\nvelocity = 1e-3\n",
            {"drive.velocity=2e-3", "lattice.nx = 7", "material.grad_div=\"navier\"",
             "material.poisson_ratio=0.3", "output.traces=[1, 2]", "run.initial=sliding"});
  CHECK(c.drive.velocity == 2e-3);
  CHECK(c.lattice.nx == 7);
  CHECK(c.material.grad_div == GradDiv::navier);
  CHECK(c.output.trace_ids == std::vector<int>{1, 2});
  CHECK(c.run.initial == InitialState::sliding);  // a bare word is taken as a string
  const Case k = parse("", {"interface.contacts=[{site=[2, 3], v_star=1e-4}]"});
  REQUIRE(k.interface.contacts.size() == 1);
  CHECK((k.interface.contacts[0].ix == 2 && k.interface.contacts[0].iy == 3 &&
         k.interface.contacts[0].line == 0));
}

TEST_CASE("errors in --set are reported as --set", "[case][set]") {
  REQUIRE_THROWS_WITH(parse("[interface]\ncoverage = 0.5\n", {"interface.coverage=2"}),
                      "--set interface.coverage: must be in (0, 1], got 2");
  REQUIRE_THROWS_WITH(parse("", {"lattice.nx=2.5"}),
                      "--set lattice.nx: expected an integer, got floating-point");
  REQUIRE_THROWS_WITH(parse("", {"drive.velocty=1"}),
                      "--set drive.velocty: unknown key 'velocty' (did you mean 'velocity'?)");
  REQUIRE_THROWS_WITH(parse("", {"driv.velocity=1"}),
                      Catch::StartsWith("--set driv.velocity: unknown section 'driv'"));
  REQUIRE_THROWS_WITH(parse("", {"drive.velocity=[1,"}),
                      Catch::StartsWith("--set drive.velocity: malformed TOML value"));
  REQUIRE_THROWS_WITH(parse("", {"drive.velocity"}),
                      "--set drive.velocity: expected section.key=value");
  REQUIRE_THROWS_WITH(parse("", {"velocity=1"}), "--set velocity=1: expected section.key=value");
  REQUIRE_THROWS_WITH(parse("", {"output.traces=[0, 99]"}),
                      "--set output.traces[1]: must be a contact id in [0, 23), got 99");
  // A file value made wrong by an override elsewhere is still blamed on its own line.
  REQUIRE_THROWS_WITH(
      parse("[interface]\ncontacts = [{site = [5, 1], v_star = 1e-4}]\n", {"lattice.nx=5"}),
      Catch::StartsWith(
          "cases/t.toml:2: interface.contacts[0].site: must lie on the 5x15 interface"));
}

TEST_CASE("overrides of another origin are reported by their key alone", "[case][set]") {
  // The Python module's dicts: no "--set" in front of a key the user never typed as one.
  const auto dict = [](const std::vector<std::string>& overrides) {
    return stickslip::parse_case("", "<dict>", overrides, "");
  };
  REQUIRE_THROWS_WITH(dict({"interface.coverage=2"}),
                      "interface.coverage: must be in (0, 1], got 2");
  REQUIRE_THROWS_WITH(dict({"drive.velocty=1"}),
                      "drive.velocty: unknown key 'velocty' (did you mean 'velocity'?)");
  REQUIRE_THROWS_WITH(dict({"drive.velocity=[1,"}),
                      Catch::StartsWith("drive.velocity: malformed TOML value"));
  REQUIRE_THROWS_WITH(dict({"velocity=1"}), "velocity=1: expected section.key=value");
  REQUIRE_THROWS_WITH(dict({"run.t_end=1e-3", "run.average_from=2e-3"}),
                      "run.average_from: must be in [0, run.t_end = 0.001), got 0.002");
}

TEST_CASE("to_json lists every resolved parameter", "[case]") {
  const Case c = parse(R"([lattice]
nx = 6
[material]
grad_div = "navier"
poisson_ratio = 0.3
[interface]
contacts = [{ site = [4, 2], v_star = 4.75e-4 }, { site = [1, 5], v_star = 1e-3 }]
[output]
dir = "out"
traces = [1]
)");
  const nlohmann::json j = to_json(c);
  CHECK(j.at("source") == "cases/t.toml");
  CHECK(j.at("lattice").at("nx") == 6);
  CHECK(j.at("lattice").at("ny") == 15);  // defaults filled in
  CHECK(j.at("material").at("grad_div") == "navier");
  CHECK(j.at("material").at("poisson_ratio") == 0.3);
  // Listed contacts replace coverage and seed: the resolved case shows neither.
  CHECK_FALSE(j.at("interface").contains("seed"));
  CHECK_FALSE(j.at("interface").contains("coverage"));
  // Unset values are left out, not written as a value that reads differently.
  CHECK_FALSE(to_json(parse("")).at("solver").contains("audit_bound"));
  CHECK_FALSE(to_json(parse("")).at("output").contains("dir"));
  CHECK(to_json(parse("")).at("interface").at("seed") == 1);
  CHECK(j.at("interface").at("contacts") ==
        nlohmann::json::parse(
            R"([{"site": [4, 2], "v_star": 4.75e-4}, {"site": [1, 5], "v_star": 1e-3}])"));
  CHECK(j.at("run").at("initial") == "rest");
  CHECK(j.at("solver").at("method") == "auto");
  CHECK(j.at("solver").at("max_steps") == 50'000'000);
  CHECK(j.at("output").at("dir") == "cases/out");
  CHECK(j.at("output").at("traces") == nlohmann::json::array({1}));
  CHECK(to_json(parse("[output]\ntraces = \"all\"")).at("output").at("traces") == "all");
  CHECK(to_json(parse("")).at("output").at("traces") == "none");
  CHECK(to_json(parse("")).at("interface").at("contacts") == nlohmann::json::array());
}

TEST_CASE("read_case reads a file and resolves output.dir next to it", "[case]") {
  namespace fs = std::filesystem;
  const test::TempDir tmp("stickslip_test_case_reader");
  const fs::path& dir = tmp.path;
  const fs::path file = dir / "run.toml";
  std::ofstream(file) << "[drive]\nvelocity = 5e-4\n[output]\ndir = \"results\"\n";
  const Case c = read_case(file, {"drive.velocity=6e-4"});
  CHECK(c.source == file);
  CHECK(c.drive.velocity == 6e-4);
  CHECK(c.output.dir == dir / "results");

  std::ofstream(file) << "[drive]\nvelocity = -1\n";
  REQUIRE_THROWS_WITH(read_case(file), file.string() + ":2: drive.velocity: must be >= 0, got -1");
  fs::remove_all(dir);
  REQUIRE_THROWS_WITH(read_case(file),
                      file.string() + ": cannot read case file: No such file or directory");
}

TEST_CASE("to_toml reads back as the same case, for every case file and extreme values", "[case]") {
  auto same = [](const Case& c) {
    const Case back = parse_case(to_toml(c), "elsewhere/saved.toml");
    auto a = to_json(c), b = to_json(back);
    a.erase("source");
    b.erase("source");
    if (!c.output.dir.empty())
      a["output"]["dir"] = std::filesystem::absolute(c.output.dir).string();
    CHECK(b == a);
  };
  int cases = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(STICKSLIP_SOURCE_DIR) / "cases")) {
    std::ifstream in(entry.path());
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    if (text.find("[sweep]") != std::string::npos) continue;
    INFO(entry.path());
    same(read_case(entry.path()));
    ++cases;
  }
  CHECK(cases >= 7);
  const Case extreme = parse(R"([interface]
contacts = [{site = [1, 2], v_star = 1e-300}, {site = [4, 2], v_star = 2.0000000000000004e-3}]
[run]
t_end = 0.30000000000000004
[solver]
rtol = 1e-5
atol_velocity = 3e-11
threads = 2
[output]
dir = "a \"quoted\" dir \\ é"
traces = [1, 0]
events = "none"
format = "hdf5"
)");
  same(extreme);
  const std::string text = to_toml(extreme);
  CHECK_THAT(text, Contains("t_end = 0.30000000000000004"));
  CHECK(text.find("audit_bound") == std::string::npos);  // unset: a file may not say 0
  // The fewest digits, as a person writes them: 4.75e-4 is 0.000475, not 0.00047499999999999999.
  CHECK_THAT(to_toml(parse("[interface]\ncontacts = [{site = [1, 2], v_star = 4.75e-4}]\n")),
             Contains("{site = [1, 2], v_star = 0.000475}"));
}
