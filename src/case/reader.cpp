// Case-file reader. Every key is one entry of the schema below (section, key,
// how to read it and write it back, unit and meaning); the reader walks the
// parsed TOML against that table, to_json writes a Case through it, and
// `stickslip keys` and docs/keys.md print it, so adding a parameter is adding
// one entry (and its field, which tests/test_case_keys.cpp checks). Checks that involve two keys
// run afterwards on the filled Case. Errors are blamed on the node at fault:
// toml++ records where each node came from, and nodes parsed from --set carry
// the source name "--set", so an override is reported as such and not as a line
// of the file.

#include "stickslip/case/reader.hpp"

#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>
#include <utility>

#include "stickslip/case/keys.hpp"
#include "stickslip/case/methods.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/case/toml_text.hpp"

namespace stickslip {

namespace {

using namespace std::string_literals;
using namespace toml_text;

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr std::string_view kOverride = "--set";

bool from_override(const toml::node& n) {
  return n.source().path && *n.source().path == kOverride;
}

// The state of one parse: the source name for messages, and the nodes that the
// cross-key checks need to blame.
struct Reader {
  std::string source;
  std::string override_prefix;  // "--set " before an override's key in messages
  std::map<std::string, const toml::node*, std::less<>> given;  // "section.key" -> its value
  std::vector<const toml::node*> contact_sites, trace_ids,
      event_ids;  // parallel to the Case's lists

  std::string message(const toml::node& at, std::string_view key, std::string_view what) const {
    const auto& src = at.source();
    if (from_override(at)) return override_prefix + std::string(key) + ": " + std::string(what);
    std::string where = src.begin.line ? source + ":" + std::to_string(src.begin.line) : source;
    return where + ": " + std::string(key) + ": " + std::string(what);
  }

  [[noreturn]] void fail(const toml::node& at, std::string_view key, std::string_view what) const {
    throw CaseError(message(at, key, what));
  }

  [[noreturn]] void fail_unknown(const toml::node& at, std::string_view key,
                                 std::string_view what) const {
    throw UnknownKeyError(message(at, key, what));
  }

  // A cross-key problem is blamed on the first key of `choices` the user gave,
  // worded for that key. One always is: the defaults are consistent.
  [[noreturn]] void fail_first(
      std::initializer_list<std::pair<std::string_view, std::string>> choices) const {
    for (const auto& [key, what] : choices)
      if (auto it = given.find(key); it != given.end()) fail(*it->second, key, what);
    throw std::logic_error("stickslip: inconsistent default parameters");
  }

  double real(const toml::node& n, std::string_view key) const {
    if (!n.is_number()) fail(n, key, "expected a number, got " + type_name(n));
    double x = n.is_integer() ? static_cast<double>(**n.as_integer()) : **n.as_floating_point();
    if (!std::isfinite(x)) fail(n, key, "must be finite, got " + fmt(x));
    return x;
  }

  std::int64_t integer(const toml::node& n, std::string_view key) const {
    if (auto* i = n.as_integer()) return i->get();
    fail(n, key, "expected an integer, got " + type_name(n));
  }

  int index(const toml::node& n, std::string_view key) const {  // a site coordinate or contact id
    std::int64_t i = integer(n, key);
    if (i < 0) fail(n, key, "must be >= 0, got " + std::to_string(i));
    if (i > std::numeric_limits<int>::max())
      fail(n, key, "must be <= 2147483647, got " + std::to_string(i));
    return static_cast<int>(i);
  }

  const std::string& string(const toml::node& n, std::string_view key) const {
    if (auto* s = n.as_string()) return s->get();
    fail(n, key, "expected a string, got " + type_name(n));
  }
};

// An interval of allowed values; an infinite upper end means unbounded.
struct Range {
  double lo, hi;
  bool lo_open, hi_open;
  bool contains(double x) const {
    return (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  }
  std::string text() const {
    if (std::isinf(hi)) return (lo_open ? "> " : ">= ") + fmt(lo);
    return "in "s + (lo_open ? '(' : '[') + fmt(lo) + ", " + fmt(hi) + (hi_open ? ')' : ']');
  }
};
constexpr Range kPositive{0, kInf, true, true};
constexpr Range kNonNegative{0, kInf, false, true};

// Converts one value, checks what can be checked on it alone, and stores it.
using Apply = std::function<void(Reader&, const toml::node&, const std::string& key, Case&)>;

// How a key's value is written back (to_json): null for a key left unset,
// which to_json leaves out and which reads back as unset.
using Write = std::function<nlohmann::json(const Case&)>;

// How a key is read, what it allows in words (for `stickslip keys`) and how
// it is written back (to_json): the builders below make all three from the
// same member, range or options.
struct Rule {
  Apply apply;
  std::string allowed;
  Write write;
};

// One key: how it is read, its unit and what it means. The default is the
// Case's member initialiser (case.hpp), read through to_json(Case{}).
struct Entry {
  std::string_view section, key;
  Rule rule;
  std::string_view unit;  // SI; empty: a number without unit, a word, a flag
  std::string_view help;
};

// Builders for the common kinds of entry; `s` and `m` reach the parameter: (c.*s).*m.
template <class S>
Rule real(S Case::*s, double S::*m, Range range) {
  return {[=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
            double x = r.real(n, key);
            if (!range.contains(x)) r.fail(n, key, "must be " + range.text() + ", got " + fmt(x));
            (c.*s).*m = x;
          },
          range.text(), [=](const Case& c) { return nlohmann::json((c.*s).*m); }};
}

// A real that may be left unset (0: the solver derives it), written back only
// when set.
template <class S>
Rule optional_real(S Case::*s, double S::*m, Range range) {
  Rule rule = real(s, m, range);
  rule.write = [=](const Case& c) {
    return (c.*s).*m > 0 ? nlohmann::json((c.*s).*m) : nlohmann::json();
  };
  return rule;
}

template <class S, class T>
Rule integer(S Case::*s, T S::*m, std::int64_t lo) {
  return {[=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
            std::int64_t x = r.integer(n, key);
            if (x < lo)
              r.fail(n, key, "must be >= " + std::to_string(lo) + ", got " + std::to_string(x));
            if (std::cmp_greater(x, std::numeric_limits<T>::max()))
              r.fail(n, key,
                     "must be <= " + std::to_string(std::numeric_limits<T>::max()) + ", got " +
                         std::to_string(x));
            (c.*s).*m = static_cast<T>(x);
          },
          "integer >= " + std::to_string(lo),
          [=](const Case& c) { return nlohmann::json((c.*s).*m); }};
}

// A string naming one of `options`, spelled as to_string spells them.
template <class S, class E, class... Es>
Rule choice(S Case::*s, E S::*m, Es... options) {
  std::string names;
  ((names += (names.empty() ? "\""s : ", \""s) + to_string(options) + "\""), ...);
  return {[=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
            const std::string& word = r.string(n, key);
            if (((word == to_string(options) && ((c.*s).*m = options, true)) || ...)) return;
            r.fail(n, key, "must be one of " + names + ", got \"" + printable(word) + "\"");
          },
          names, [=](const Case& c) { return nlohmann::json(to_string((c.*s).*m)); }};
}

// "auto", or the name of a row of a table of case/methods.hpp.
template <class Row, class Choice>
void read_row(Reader& r, const toml::node& n, const std::string& key, std::span<const Row> rows,
              Choice Row::*field, Choice& out) {
  const std::string& word = r.string(n, key);
  std::string names = "\"auto\"";
  if (word == "auto") {
    out = Choice::automatic;
    return;
  }
  for (const Row& row : rows) {
    if (word == row.name) {
      out = row.*field;
      return;
    }
    names += ", \"" + std::string(row.name) + "\"";
  }
  r.fail(n, key, "must be one of " + names + ", got \"" + printable(word) + "\"");
}

void read_method(Reader& r, const toml::node& n, const std::string& key, Case& c) {
  read_row(r, n, key, methods(), &MethodInfo::method, c.solver.method);
}

void read_linear_solver(Reader& r, const toml::node& n, const std::string& key, Case& c) {
  // KLU was offered and never finished a case from rest: docs/notes/performance-history.md.
  if (const auto* s = n.as_string(); s && s->get() == "klu")
    r.fail(n, key,
           "\"klu\" is no longer offered: SUNDIALS' Newton with a sparse LU of the 3D lattice "
           "stalled from rest on every case tried (one factorization takes 9.8 s on 15x15x10); "
           "use \"fft\" (the default), which solves each stage exactly");
  read_row(r, n, key, linear_solvers(), &LinearSolverInfo::solver, c.solver.linear_solver);
}

void read_dir(Reader& r, const toml::node& n, const std::string& key, Case& c) {
  const std::string& s = r.string(n, key);
  if (s.empty()) r.fail(n, key, "must not be empty (leave it out for out/<case name>)");
  c.output.dir = s;  // resolved against the case file's directory once all is read
}

void read_contacts(Reader& r, const toml::node& n, const std::string& key, Case& c) {
  const auto* list = n.as_array();
  if (!list)
    r.fail(n, key, "expected an array of {site = [ix, iy], v_star = ...}, got " + type_name(n));
  if (list->empty())
    r.fail(n, key, "must list at least one contact (leave it out for random placement)");
  auto& contacts = c.interface.contacts;
  contacts.clear();
  r.contact_sites.clear();
  for (std::size_t i = 0; i < list->size(); ++i) {
    const toml::node& entry = *list->get(i);
    const std::string name = key + "[" + std::to_string(i) + "]";
    const auto* table = entry.as_table();
    if (!table)
      r.fail(entry, name,
             "expected a table {site = [ix, iy], v_star = ...}, got " + type_name(entry));
    for (auto&& [k, v] : *table)
      if (k != "site" && k != "v_star")
        r.fail(v, name + "." + printable(k.str()),
               "unknown key '" + printable(k.str()) + "'" + suggest(k.str(), {"site", "v_star"}));
    const toml::node* site = table->get("site");
    const toml::node* v_star = table->get("v_star");
    if (!site) r.fail(entry, name, "missing site = [ix, iy]");
    if (!v_star) r.fail(entry, name, "missing v_star");
    const auto* xy = site->as_array();
    if (!xy || xy->size() != 2)
      r.fail(*site, name + ".site", "expected an array of two integers [ix, iy]");
    ExplicitContact contact{.ix = r.index(*xy->get(0), name + ".site"),
                            .iy = r.index(*xy->get(1), name + ".site"),
                            .v_star = r.real(*v_star, name + ".v_star"),
                            .line = from_override(entry) ? 0 : int(entry.source().begin.line)};
    if (!(contact.v_star > 0))
      r.fail(*v_star, name + ".v_star", "must be > 0, got " + fmt(contact.v_star));
    for (std::size_t j = 0; j < i; ++j)
      if (contacts[j].ix == contact.ix && contacts[j].iy == contact.iy)
        r.fail(*site, name + ".site",
               "site [" + std::to_string(contact.ix) + ", " + std::to_string(contact.iy) +
                   "] repeats " + key + "[" + std::to_string(j) + "]" +
                   (contacts[j].line ? " (line " + std::to_string(contacts[j].line) + ")" : ""));
    contacts.push_back(contact);
    r.contact_sites.push_back(site);
  }
}

nlohmann::json write_contacts(const Case& c) {
  nlohmann::json contacts = nlohmann::json::array();
  for (const auto& k : c.interface.contacts)
    contacts.push_back({{"site", nlohmann::json::array({k.ix, k.iy})}, {"v_star", k.v_star}});
  return contacts;
}

// "all", "none" or a list of distinct contact ids, for traces and for events.
Rule contact_selection(ContactSelection OutputParams::*which, std::vector<int> OutputParams::*ids,
                       std::vector<const toml::node*> Reader::*nodes) {
  return {[=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
            auto& out = c.output;
            auto& list = out.*ids;
            list.clear();
            (r.*nodes).clear();
            if (auto* s = n.as_string(); s && (s->get() == "all" || s->get() == "none")) {
              out.*which = s->get() == "all" ? ContactSelection::all : ContactSelection::none;
              return;
            }
            const auto* array = n.as_array();
            if (!array) {
              std::string got =
                  n.is_string() ? "\"" + printable(n.as_string()->get()) + "\"" : type_name(n);
              r.fail(n, key, "must be \"all\", \"none\" or an array of contact ids, got " + got);
            }
            out.*which = ContactSelection::list;
            for (std::size_t i = 0; i < array->size(); ++i) {
              const std::string name = key + "[" + std::to_string(i) + "]";
              int id = r.index(*array->get(i), name);
              if (auto it = std::find(list.begin(), list.end(), id); it != list.end())
                r.fail(*array->get(i), name,
                       "contact " + std::to_string(id) + " repeats " + key + "[" +
                           std::to_string(it - list.begin()) + "]");
              list.push_back(id);
              (r.*nodes).push_back(array->get(i));
            }
          },
          "\"all\", \"none\" or [contact ids]",
          [=](const Case& c) {
            const auto& out = c.output;
            return out.*which == ContactSelection::all    ? nlohmann::json("all")
                   : out.*which == ContactSelection::none ? nlohmann::json("none")
                                                          : nlohmann::json(out.*ids);
          }};
}

Rule boolean(bool OutputParams::*m) {
  return {[=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
            const auto* b = n.as_boolean();
            if (!b) r.fail(n, key, "expected true or false, got " + type_name(n));
            c.output.*m = b->get();
          },
          "true, false", [=](const Case& c) { return nlohmann::json(c.output.*m); }};
}

// interface.coverage and seed place contacts at random: a case that lists its
// contacts uses neither, so its resolved form does not show them.
Rule unless_listed(Rule rule) {
  rule.write = [write = rule.write](const Case& c) {
    return c.interface.contacts.empty() ? write(c) : nlohmann::json();
  };
  return rule;
}

// run.average_from: a time, or "auto" (found from F_f at the end of the run).
Rule average_from_rule() {
  Rule rule = real(&Case::run, &RunParams::average_from, kNonNegative);
  const auto read_time = rule.apply;
  rule.apply = [=](Reader& r, const toml::node& n, const std::string& key, Case& c) {
    if (n.is_string()) {
      if (r.string(n, key) != "auto")
        r.fail(n, key,
               "must be " + kNonNegative.text() + " or \"auto\", got \"" +
                   printable(r.string(n, key)) + "\"");
      c.run.average_auto = true;
      c.run.average_from = 0.0;
      return;
    }
    read_time(r, n, key, c);
    c.run.average_auto = false;
  };
  rule.allowed = kNonNegative.text() + ", \"auto\"";
  rule.write = [](const Case& c) {
    return c.run.average_auto ? nlohmann::json("auto") : nlohmann::json(c.run.average_from);
  };
  return rule;
}

// "auto" and the names of a table's rows (case/methods.hpp), as read_row takes them.
template <class Row>
std::string row_names(std::span<const Row> rows) {
  std::string names = "\"auto\"";
  for (const Row& row : rows) names += ", \"" + std::string(row.name) + "\"";
  return names;
}

// Every key of a case file: section, key, how it is read (with its allowed
// values), unit and meaning. `stickslip keys` and docs/keys.md print this
// table, with each default read from to_json(Case{}); a key added here
// without its unit and meaning does not compile.
const std::vector<Entry>& schema() {
  static const std::vector<Entry> entries = {
      {"lattice", "nx", integer(&Case::lattice, &LatticeParams::nx, 1), "nodes",
       "Nx: nodes along x (periodic)"},
      {"lattice", "ny", integer(&Case::lattice, &LatticeParams::ny, 1), "nodes",
       "Ny: nodes along y (periodic)"},
      {"lattice", "nz", integer(&Case::lattice, &LatticeParams::nz, 2), "nodes",
       "Nz: layers along z; layer 0 touches the substrate, the top layer is driven"},
      {"lattice", "spacing", real(&Case::lattice, &LatticeParams::spacing, kPositive), "m",
       "a: lattice spacing; each node has mass m = ρ a³"},
      {"material", "density", real(&Case::material, &MaterialParams::density, kPositive), "kg/m³",
       "ρ: mass density"},
      {"material", "youngs_modulus",
       real(&Case::material, &MaterialParams::youngs_modulus, kPositive), "Pa",
       "E: Young's modulus"},
      {"material", "poisson_ratio",
       real(&Case::material, &MaterialParams::poisson_ratio, Range{-1, 0.5, true, false}), "",
       "ν: Poisson's ratio"},
      {"material", "grad_div",
       choice(&Case::material, &MaterialParams::grad_div, GradDiv::paper, GradDiv::navier), "",
       "G2 = (1+2ν) G1, the paper's Eq. (1) (\"paper\"), or the textbook G1/(1−2ν) "
       "(\"navier\", needs ν < 0.5) (MODEL.md §2)"},
      {"damping", "bulk", real(&Case::damping, &DampingParams::bulk, kNonNegative), "",
       "η̂ = η/ω0: damping on every lattice face (MODEL.md §4)"},
      {"damping", "contact", real(&Case::damping, &DampingParams::contact, kNonNegative), "",
       "η̂_c = η_c/ω0: viscous damping of each contact (MODEL.md §6)"},
      {"interface", "coverage",
       unless_listed(real(&Case::interface, &InterfaceParams::coverage, Range{0, 1, true, false})),
       "", "θ requested: N_c = floor(θ Nx Ny / R² + 0.5) contacts placed at random"},
      {"interface", "seed", unless_listed(integer(&Case::interface, &InterfaceParams::seed, 0)), "",
       "seed of the random placement: sites and their v*"},
      {"interface", "shear_stress",
       real(&Case::interface, &InterfaceParams::shear_stress, kPositive), "Pa",
       "τ_f: a contact's force scale is f0 = a² τ_f (MODEL.md §6)"},
      {"interface", "law", choice(&Case::interface, &InterfaceParams::law, ContactLawName::paper),
       "",
       "the contact law (MODEL.md §6): \"paper\", F = −[ε f0 φ(|s|/v*) ŝ + m η_c s] with "
       "φ(r) = exp(−c (log10 r)²), slipping while |s| > κ v*"},
      {"interface", "shape", real(&Case::interface, &InterfaceParams::shape, kPositive), "",
       "c in φ(r) = exp(−c (log10 r)²), the contact force's dependence on r = |s|/v*"},
      {"interface", "v_m", real(&Case::interface, &InterfaceParams::v_m, kPositive), "m/s",
       "v_m: centre of the log-uniform v* distribution"},
      {"interface", "spread", real(&Case::interface, &InterfaceParams::spread, kNonNegative),
       "decades", "δ: half-width of log10 v*, drawn uniformly in [log10 v_m − δ, log10 v_m + δ]"},
      {"interface", "epsilon", real(&Case::interface, &InterfaceParams::epsilon, kPositive), "",
       "ε: force scaling of the contacts (MODEL.md §6)"},
      {"interface", "max_pressure",
       real(&Case::interface, &InterfaceParams::max_pressure, kPositive), "Pa",
       "P0: the normal load is F_N = ε θ P0 Nx Ny a² (MODEL.md §7)"},
      {"interface", "slip_threshold",
       real(&Case::interface, &InterfaceParams::slip_threshold, kPositive), "",
       "κ: a contact slips while |s| > κ v* (MODEL.md §9)"},
      {"interface", "patch", integer(&Case::interface, &InterfaceParams::patch, 1), "nodes",
       "R: every contact is an R×R square of bottom nodes (MODEL.md §14); 1 is the paper's "
       "single-site contact"},
      {"interface",
       "contacts",
       {read_contacts, "[{ site = [ix, iy], v_star = ... }, ...]: at least one, sites distinct",
        write_contacts},
       "",
       "explicit contacts, numbered in the list's order (v_star in m/s); replaces coverage and "
       "seed"},
      {"drive", "velocity", real(&Case::drive, &DriveParams::velocity, kNonNegative), "m/s",
       "v: speed of the driving plate"},
      {"run", "t_end", real(&Case::run, &RunParams::t_end, kPositive), "s",
       "end of the run (a restart may raise it)"},
      {"run", "average_from", average_from_rule(), "s",
       "t_avg: μ averages F_f over [t_avg, t_end]; must be < t_end. \"auto\": from where F_f's "
       "loading transient ends, found from F_f itself at the end of the run (its first block "
       "slip, or later where the first cycles bias the mean)"},
      {"run", "initial",
       choice(&Case::run, &RunParams::initial, InitialState::rest, InitialState::sliding), "",
       "start at rest (u = w = 0) or sliding (w_x = v everywhere)"},
      {"run", "checkpoint_every", real(&Case::run, &RunParams::checkpoint_every, kNonNegative), "s",
       "simulated time between checkpoints; 0: none"},
      {"solver",
       "method",
       {read_method, row_names(methods()),
        [](const Case& c) { return nlohmann::json(to_string(c.solver.method)); }},
       "",
       "the integrator; \"auto\" chooses one for the case (docs/USAGE.md, \"Methods and "
       "accuracy\")"},
      {"solver",
       "linear_solver",
       {read_linear_solver, row_names(linear_solvers()),
        [](const Case& c) { return nlohmann::json(to_string(c.solver.linear_solver)); }},
       "",
       "how dirk and bdf solve their stage equations (those methods only); \"auto\" is \"fft\""},
      {"solver", "order", integer(&Case::solver, &SolverParams::order, 0), "",
       "the method's order; 0: its default (bdf: 2)"},
      {"solver", "step", real(&Case::solver, &SolverParams::step, kNonNegative), "s",
       "> 0: fixed step, adaptivity off (ARKStep's methods); 0: adaptive"},
      // Below 1e-12 the error test asks for more than double precision gives
      // over a run's steps (SUNDIALS fails mid-run); above 1e-2 the energy
      // audit, bounded by 100 × rtol, checks nothing.
      {"solver", "rtol", real(&Case::solver, &SolverParams::rtol, Range{1e-12, 1e-2, false, false}),
       "",
       "relative tolerance; above 1e-5 slip counts and times are not to be trusted (summary.json "
       "warns)"},
      {"solver", "atol_displacement",
       optional_real(&Case::solver, &SolverParams::atol_displacement, kPositive), "m",
       "absolute tolerance of displacements; unset: rtol times the case's scale"},
      {"solver", "atol_velocity",
       optional_real(&Case::solver, &SolverParams::atol_velocity, kPositive), "m/s",
       "absolute tolerance of velocities; unset: rtol times the case's scale"},
      {"solver", "threads", integer(&Case::solver, &SolverParams::threads, 0), "",
       "OpenMP threads of the run; 0: every core (or OMP_NUM_THREADS) from 1000 lattice nodes "
       "up, one below; results do not depend on it"},
      {"solver", "max_steps", integer(&Case::solver, &SolverParams::max_steps, 1), "",
       "most steps over the whole run"},
      {"solver", "multirate_min_fast", integer(&Case::solver, &SolverParams::multirate_min_fast, 1),
       "",
       "method = \"multirate\": the fewest fast contacts it steps on their own sub-steps, a lone "
       "one (at most one contact on the eight sites around it) counting 8, or the whole bar where "
       "most contacts are lone and they count it; with fewer, the whole step follows them (single "
       "rate); after a step with contacts apart, 1/8 as many"},
      {"solver", "audit_bound", optional_real(&Case::solver, &SolverParams::audit_bound, kPositive),
       "",
       "largest accepted |energy-audit residual| at t_end, beyond which the run fails; unset: 100 "
       "× rtol, or 1e-4 for a fixed step"},
      {"output",
       "dir",
       {read_dir, "a path, relative to the case file",
        [](const Case& c) {  // unset: not written (a case file cannot spell it empty)
          return c.output.dir.empty() ? nlohmann::json() : nlohmann::json(c.output.dir.string());
        }},
       "",
       "output directory, relative to the case file's directory (given with --set: to the "
       "working directory, as --out); unset: out/ and the case file's stem, in the working "
       "directory"},
      {"output", "interval", real(&Case::output, &OutputParams::interval, kPositive), "s",
       "time between rows of friction.csv and traces.csv"},
      {"output", "max_rows", integer(&Case::output, &OutputParams::max_rows, 1), "",
       "most rows t_end / interval may give a table, refused before the run (a guard against "
       "typos)"},
      {"output", "traces",
       contact_selection(&OutputParams::traces, &OutputParams::trace_ids, &Reader::trace_ids), "",
       "contacts whose traces traces.csv records"},
      {"output", "events",
       contact_selection(&OutputParams::events, &OutputParams::event_ids, &Reader::event_ids), "",
       "contacts whose stick/slip transitions are located"},
      {"output", "steps", boolean(&OutputParams::steps), "", "write steps.csv"},
      {"output", "attempts", boolean(&OutputParams::attempts), "",
       "write attempts.csv: every attempt at a coarse step, its errors, verdict and worst "
       "component (method = \"multirate\", or \"auto\" where it chooses multirate)"},
      {"output", "final_state", boolean(&OutputParams::final_state), "",
       "write final_state.csv, and keep checkpoint.bin at t_end so that a later run.t_end can "
       "continue the run (run --restart)"},
      {"output", "signals", boolean(&OutputParams::signals), "",
       "write signals.csv (block velocity, acoustic signal)"},
      {"output", "format",
       choice(&Case::output, &OutputParams::format, OutputFormat::csv, OutputFormat::hdf5), "",
       "one CSV file per table, or one HDF5 file (run.h5) with a group per table"},
  };
  return entries;
}

std::vector<std::string_view> sections() {
  std::vector<std::string_view> out;
  for (const auto& e : schema())
    if (std::find(out.begin(), out.end(), e.section) == out.end()) out.push_back(e.section);
  return out;
}

std::vector<std::string_view> keys_of(std::string_view section) {
  std::vector<std::string_view> out;
  for (const auto& e : schema())
    if (e.section == section) out.push_back(e.key);
  return out;
}

const Entry* find_entry(std::string_view section, std::string_view key) {
  for (const auto& e : schema())
    if (e.section == section && e.key == key) return &e;
  return nullptr;
}

std::string unknown_section(std::string_view name) {
  return "unknown section '" + printable(name) + "'" + suggest(name, sections());
}

std::string unknown_key(std::string_view section, std::string_view key) {
  return "unknown key '" + printable(key) + "'" + suggest(key, keys_of(section));
}

std::string trim(std::string_view s) {
  auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
  return b == std::string_view::npos ? "" : std::string(s.substr(b, e - b + 1));
}

// Puts one "section.key=value" into the parsed file, replacing what was there.
// `prefix` ("--set ") starts every message about the override.
void apply_override(toml::table& root, std::string_view text, const std::string& prefix) {
  auto eq = text.find('=');
  std::string key = trim(text.substr(0, eq));
  auto dot = key.find('.');
  if (eq == std::string_view::npos || dot == std::string::npos || dot == 0 || dot + 1 == key.size())
    throw CaseError(prefix + printable(text) + ": expected section.key=value");
  std::string section = key.substr(0, dot), name = key.substr(dot + 1);
  key = printable(key);
  if (keys_of(section).empty())
    throw UnknownKeyError(prefix + key + ": " + unknown_section(section));
  if (!find_entry(section, name))
    throw UnknownKeyError(prefix + key + ": " + unknown_key(section, name));

  std::string value = trim(text.substr(eq + 1));
  toml::table parsed;
  try {
    parsed = parse_toml("v = " + value, kOverride);
  } catch (const TomlSyntaxError& e) {
    // A bare word (navier, all) is taken as a string so the shell needs no quotes around quotes.
    bool word = !value.empty() && std::isalpha(static_cast<unsigned char>(value[0])) &&
                std::all_of(value.begin(), value.end(), [](unsigned char ch) {
                  return std::isalnum(ch) || ch == '_' || ch == '-';
                });
    if (!word)
      throw CaseError(prefix + key + ": malformed TOML value '" + printable(value) +
                      "': " + e.description);
    parsed = parse_toml("v = \"" + value + "\"", kOverride);
  }
  toml::node* sec = root.get(section);
  if (!sec) sec = &root.insert(section, toml::table{}).first->second;
  // A section that is not a table is the file's own error, reported by the reader.
  if (auto* table = sec->as_table()) table->insert_or_assign(name, std::move(*parsed.get("v")));
}

void read_tables(Reader& r, const toml::table& root, Case& c) {
  for (auto&& [section_key, section] : root) {
    const std::string name = printable(section_key.str());
    if (keys_of(section_key.str()).empty())
      r.fail_unknown(section, name, unknown_section(section_key.str()));
    const auto* table = section.as_table();
    if (!table) r.fail(section, name, "expected a table [" + name + "], got " + type_name(section));
    for (auto&& [k, v] : *table) {
      const std::string key = name + "." + printable(k.str());
      const Entry* entry = find_entry(section_key.str(), k.str());
      if (!entry) r.fail_unknown(v, key, unknown_key(section_key.str(), k.str()));
      entry->rule.apply(r, v, key, c);
      r.given[key] = &v;
    }
  }
}

// "1e+15", "3.2e+04": a large count for messages, to three digits.
std::string rounded(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

// "3.2 GiB": a byte count for messages.
std::string bytes_text(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024 && u < 6) bytes /= 1024, ++u;
  char text[32];
  std::snprintf(text, sizeof text, "%.3g %s", bytes, units[u]);
  return text;
}

// Peak memory of a run, from its lattice and its method's row ("auto":
// dirk's, which it mostly chooses).
double memory_estimate(const Case& c) {
  const double nodes = double(c.lattice.nx) * c.lattice.ny * c.lattice.nz;
  const Method m = c.solver.method == Method::automatic ? Method::dirk : c.solver.method;
  return nodes * method_info(m).bytes_per_node;
}

double physical_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page)
                               : std::numeric_limits<double>::infinity();
}

long long contact_count(const Case& c) {
  if (!c.interface.contacts.empty()) return static_cast<long long>(c.interface.contacts.size());
  return stickslip::contact_count(c.interface.coverage, c.lattice.nx, c.lattice.ny,
                                  c.interface.patch);
}

void check_consistency(const Reader& r, const Case& c) {
  const double nu = c.material.poisson_ratio;
  if (c.material.grad_div == GradDiv::navier && !(nu < 0.5))
    r.fail_first(
        {{"material.poisson_ratio",
          "must be < 0.5 with grad_div = \"navier\" (G1/(1-2ν) diverges), got " + fmt(nu)},
         {"material.grad_div",
          "\"navier\" needs poisson_ratio < 0.5 (G1/(1-2ν) diverges), but poisson_ratio is " +
              fmt(nu)}});

  const int nx = c.lattice.nx, ny = c.lattice.ny;
  const std::string lattice = std::to_string(nx) + "x" + std::to_string(ny);
  const int patch = c.interface.patch;
  const std::string patch_name = std::to_string(patch) + "x" + std::to_string(patch);
  if (patch > std::min(nx, ny)) {
    const std::string bigger = "a " + patch_name + " patch does not fit the " + lattice +
                               " interface (patch must be <= min(nx, ny))";
    r.fail_first({{"interface.patch", bigger}, {"lattice.nx", bigger}, {"lattice.ny", bigger}});
  }
  if (c.interface.contacts.empty() && contact_count(c) < 1) {
    const std::string none =
        "a " + lattice + " interface at coverage " + fmt(c.interface.coverage) +
        (patch > 1 ? " has no " + patch_name + " patch (floor(coverage*nx*ny/patch^2 + 0.5) = 0)"
                   : " has no contact (floor(coverage*nx*ny + 0.5) = 0)");
    r.fail_first({{"interface.coverage", none},
                  {"interface.patch", none},
                  {"lattice.nx", none},
                  {"lattice.ny", none}});
  }
  if (c.interface.contacts.empty() && patch > 1) {
    try {
      place_contacts(c.lattice, c.interface);
    } catch (const PlacementError& e) {
      const std::string why = std::string(e.what()) + " (random placement, MODEL.md §14): " +
                              "lower the coverage or the patch, or try another seed";
      r.fail_first({{"interface.patch", why},
                    {"interface.coverage", why},
                    {"interface.seed", why},
                    {"lattice.nx", why},
                    {"lattice.ny", why}});
    }
  }

  // coverage and seed only feed the random placement: beside an explicit list
  // they would change nothing, and a sweep over them would look like an
  // ensemble of identical runs.
  if (!c.interface.contacts.empty())
    for (const std::string_view key : {"interface.coverage", "interface.seed"})
      if (auto it = r.given.find(key); it != r.given.end())
        r.fail(*it->second, key,
               "places contacts at random, but interface.contacts lists them (" +
                   std::to_string(c.interface.contacts.size()) +
                   " contacts, so coverage = contacts/(nx*ny)): give interface.coverage and "
                   "interface.seed, or interface.contacts, not both");

  const double t_end = c.run.t_end, t_avg = c.run.average_from;
  // Refused before anything is written: what cannot finish.
  if (const double rows = std::floor(t_end / c.output.interval) + 1;
      rows > static_cast<double>(c.output.max_rows)) {
    // friction.csv's row: three numbers of ~17 characters.
    const std::string why = "t_end / interval = " + rounded(rows) +
                            " rows per table (friction.csv ~" + bytes_text(rows * 3 * 17) +
                            "), over output.max_rows = " + std::to_string(c.output.max_rows) +
                            ": raise output.interval, or output.max_rows if that is meant";
    r.fail_first({{"output.interval", why}, {"run.t_end", why}, {"output.max_rows", why}});
  }
  if (const double need = memory_estimate(c), have = physical_memory(); need > have) {
    const std::string why = "a " + std::to_string(nx) + "x" + std::to_string(ny) + "x" +
                            std::to_string(c.lattice.nz) + " lattice needs ~" + bytes_text(need) +
                            " of memory with method = \"" + to_string(c.solver.method) +
                            "\", and this machine has " + bytes_text(have);
    r.fail_first(
        {{"lattice.nx", why}, {"lattice.ny", why}, {"lattice.nz", why}, {"solver.method", why}});
  }
  if (!(t_avg < t_end))
    r.fail_first(
        {{"run.average_from", "must be in [0, run.t_end = " + fmt(t_end) + "), got " + fmt(t_avg)},
         {"run.t_end", "must be > run.average_from = " + fmt(t_avg) + ", got " + fmt(t_end)}});

  const auto& explicit_contacts = c.interface.contacts;
  for (std::size_t i = 0; i < explicit_contacts.size(); ++i) {
    const auto& k = explicit_contacts[i];
    if (k.ix >= nx || k.iy >= ny)
      r.fail(*r.contact_sites[i], "interface.contacts[" + std::to_string(i) + "].site",
             "must lie on the " + lattice + " interface (ix < " + std::to_string(nx) + ", iy < " +
                 std::to_string(ny) + "), got [" + std::to_string(k.ix) + ", " +
                 std::to_string(k.iy) + "]");
  }
  if (patch > 1) {
    std::vector<Contact> placed;
    for (const auto& k : explicit_contacts) placed.push_back({k.ix, k.iy, k.v_star});
    if (const auto overlap = first_overlap(placed, patch, nx, ny)) {
      const auto [i, j] = *overlap;
      const auto& first = explicit_contacts[i];
      r.fail(*r.contact_sites[j], "interface.contacts[" + std::to_string(j) + "].site",
             "its " + patch_name + " patch overlaps that of contacts[" + std::to_string(i) +
                 "] at [" + std::to_string(first.ix) + ", " + std::to_string(first.iy) + "]" +
                 (first.line ? " (line " + std::to_string(first.line) + ")" : "") +
                 " (patches wrap around the " + lattice + " interface)");
    }
  }

  const long long n = contact_count(c);
  auto check_ids = [&](const std::vector<int>& ids, const std::vector<const toml::node*>& nodes,
                       const std::string& key) {
    for (std::size_t i = 0; i < ids.size(); ++i)
      if (ids[i] >= n)
        r.fail(*nodes[i], key + "[" + std::to_string(i) + "]",
               "must be a contact id in [0, " + std::to_string(n) + "), got " +
                   std::to_string(ids[i]));
  };
  check_ids(c.output.trace_ids, r.trace_ids, "output.traces");
  check_ids(c.output.event_ids, r.event_ids, "output.events");

  // The method's row (case/methods.hpp); "auto" is checked against imex's
  // (validated_as, case/case.hpp).
  const MethodInfo& m = method_info(validated_as(c.solver.method));
  const SolverParams& s = c.solver;
  const std::string name = "\"" + std::string(to_string(s.method)) + "\"";
  if (!m.error_estimate && !(s.step > 0))
    r.fail_first({{"solver.step", "must be > 0 with method = " + name + " (a fixed-step method)"},
                  {"solver.method", name + " is fixed-step: it needs [solver] step > 0"}});
  if (!m.fixed_step && s.step > 0)
    r.fail_first({{"solver.step", "must be 0 with method = " + name + " (" +
                                      package_name(m.package) + " has no fixed step)"},
                  {"solver.method", name + " is adaptive only: leave [solver] step out"}});
  if (s.linear_solver != LinearSolver::automatic && !m.whole_implicit) {
    std::string implicit_methods;  // "\"dirk\" or \"bdf\""
    for (const MethodInfo& other : methods())
      if (other.whole_implicit)
        implicit_methods +=
            (implicit_methods.empty() ? "\"" : " or \"") + std::string(other.name) + "\"";
    r.fail_first(
        {{"solver.linear_solver", "applies to method = " + implicit_methods + " only, not " + name},
         {"solver.method", "solves no linear systems: leave [solver] linear_solver out"}});
  }
  // Only a stepper of this project's own sees its attempts; SUNDIALS' packages
  // report accepted steps only ("auto" may choose multirate: allowed).
  if (c.output.attempts && s.method != Method::automatic && m.package != Package::own)
    r.fail_first(
        {{"output.attempts",
          "applies to method = \"multirate\" only, not " + name +
              " (whose attempts SUNDIALS keeps to itself: [output] steps records its steps)"},
         {"solver.method", name + " records no attempts: leave [output] attempts out"}});
  // What the method's row asks of the case (case/methods.cpp says why).
  if (m.single_site_only && c.interface.patch != 1)
    r.fail_first({{"interface.patch",
                   "must be 1 with method = " + name + " (it steps single-site contacts)"},
                  {"solver.method", name + " steps single-site contacts: leave patch at 1"}});
  const std::string least = std::to_string(m.min_nodes);
  for (const auto& [key, nodes] : {std::pair<std::string, int>{"lattice.nx", c.lattice.nx},
                                   {"lattice.ny", c.lattice.ny},
                                   {"lattice.nz", c.lattice.nz}})
    if (nodes < m.min_nodes)
      r.fail_first({{key, "must be >= " + least + " with method = " + name + ", got " +
                              std::to_string(nodes)},
                    {"solver.method", name + " needs a lattice of at least " + least + "x" + least +
                                          "x" + least + " nodes"}});
  if (s.order != 0 && (s.order < m.min_order || s.order > m.max_order))
    r.fail_first({{"solver.order", "must be 0 (default) or in [" + std::to_string(m.min_order) +
                                       ", " + std::to_string(m.max_order) + "] for method = " +
                                       name + ", got " + std::to_string(s.order)},
                  {"solver.method", "does not offer order " + std::to_string(s.order)}});
}

// A default as a case file spells it ("6.5e6", "\"paper\""), from
// to_json(Case{}); "unset" where it is absent or the key's own rule refuses it
// (an empty output.dir, audit_bound 0: values that mean unset).
std::string default_text(const Entry& e, const nlohmann::json& defaults) {
  const auto section = defaults.find(std::string(e.section));
  if (section == defaults.end() || !section->contains(std::string(e.key))) return "unset";
  const nlohmann::json& v = (*section)[std::string(e.key)];
  std::string text = v.is_number_float() ? fmt(v.get<double>()) : v.dump();
  for (const auto& [long_form, short_form] : {std::pair{"e+0", "e"}, {"e+", "e"}, {"e-0", "e-"}})
    if (auto at = text.find(long_form); at != std::string::npos)
      text.replace(at, std::string_view(long_form).size(), short_form);
  try {
    const toml::table parsed = parse_toml("v = " + text, "default");
    Reader r{"default", "", {}, {}, {}, {}};
    Case c;
    e.rule.apply(r, *parsed.get("v"), std::string(e.key), c);
  } catch (const CaseError&) {
    return "unset";
  } catch (const TomlSyntaxError&) {
    return "unset";
  }
  return text;
}

}  // namespace

// Each key's value as its schema row writes it, in the case file's sections
// and key names, so a summary.json reads back as a case (apart from
// `source`); a key unset (null) is left out.
nlohmann::json to_json(const Case& c) {
  nlohmann::json out = {{"source", c.source.string()}};
  for (const Entry& e : schema()) {
    nlohmann::json value = e.rule.write(c);
    if (!value.is_null()) out[std::string(e.section)][std::string(e.key)] = std::move(value);
  }
  return out;
}

const std::vector<CaseKey>& case_keys() {
  static const std::vector<CaseKey> keys = [] {
    const nlohmann::json defaults = to_json(Case{});
    std::vector<CaseKey> out;
    for (const Entry& e : schema())
      out.push_back({std::string(e.section), std::string(e.key), default_text(e, defaults),
                     std::string(e.unit), e.rule.allowed, std::string(e.help)});
    return out;
  }();
  return keys;
}

std::string case_key_problem(std::string_view dotted_key) {
  const auto dot = dotted_key.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == dotted_key.size())
    return "expected section.key, got '" + printable(dotted_key) + "'";
  const auto section = dotted_key.substr(0, dot), key = dotted_key.substr(dot + 1);
  if (keys_of(section).empty()) return unknown_section(section);
  if (!find_entry(section, key)) return unknown_key(section, key);
  return {};
}

Case parse_case(std::string_view toml_text, const std::filesystem::path& source,
                const std::vector<std::string>& overrides, std::string_view override_origin) {
  const std::string prefix = override_origin.empty() ? "" : std::string(override_origin) + " ";
  Reader r{printable(source.string()), prefix, {}, {}, {}, {}};
  toml::table root;
  try {
    root = parse_toml(toml_text, std::string_view(source.native()));
  } catch (const TomlSyntaxError& e) {
    throw CaseError(r.source + ":" + std::to_string(e.line) + ": malformed TOML: " + e.description);
  }
  for (const auto& o : overrides) apply_override(root, o, prefix);

  Case c;
  c.source = source;
  read_tables(r, root, c);
  check_consistency(r, c);
  // A path is relative to where it was written: in the case file, to the
  // file's directory; on the command line (--set, or a Python dict of
  // changes), to the working directory, as --out is.
  const bool dir_overridden = std::any_of(overrides.begin(), overrides.end(), [](const auto& o) {
    const auto key = o.substr(0, o.find('='));
    const auto first = key.find_first_not_of(" \t"), last = key.find_last_not_of(" \t");
    return first != std::string::npos && key.substr(first, last - first + 1) == "output.dir";
  });
  if (!c.output.dir.empty() && c.output.dir.is_relative() && !dir_overridden)
    c.output.dir = source.parent_path() / c.output.dir;
  return c;
}

Case read_case(const std::filesystem::path& file, const std::vector<std::string>& overrides,
               std::string_view override_origin) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw CaseError(printable(file.string()) + ": cannot read case file: it is a directory");
  std::ifstream in(file, std::ios::binary);
  if (!in)
    throw CaseError(printable(file.string()) + ": cannot read case file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw CaseError(printable(file.string()) + ": cannot read case file: read error");
  return parse_case(text.str(), file, overrides, override_origin);
}

}  // namespace stickslip
