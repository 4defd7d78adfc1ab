#include "stickslip/output/summary.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "stickslip/core/json_number.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

const nlohmann::json& field(const nlohmann::json& j, const char* name) {
  if (!j.is_object() || !j.contains(name))
    throw std::invalid_argument(std::string("no \"") + name + "\"");
  return j[name];
}

double number(const nlohmann::json& j, const char* name) {
  const auto& x = field(j, name);
  if (x.is_null()) return std::nan("");
  if (!x.is_number()) throw std::invalid_argument(std::string("\"") + name + "\" is not a number");
  return x.get<double>();
}

std::optional<double> optional_number(const nlohmann::json& j, const char* name) {
  const double x = number(j, name);
  return std::isnan(x) ? std::nullopt : std::optional<double>(x);
}

// The inverses of core/events.hpp's to_json.
ContactEventStats contact_statistics_from_json(const nlohmann::json& j) {
  ContactEventStats s;
  s.contact = static_cast<int>(number(j, "contact"));
  s.slips = static_cast<long>(number(j, "slips"));
  s.mean_recurrence = number(j, "mean_recurrence");
  s.std_recurrence = number(j, "std_recurrence");
  s.mean_slip_duration = number(j, "mean_slip_duration");
  s.slipping_fraction = number(j, "slipping_fraction");
  return s;
}

Synchronization synchronization_from_json(const nlohmann::json& j) {
  Synchronization s;
  s.contact_a = static_cast<int>(number(j, "contact_a"));
  s.contact_b = static_cast<int>(number(j, "contact_b"));
  s.slip_rate_ratio = number(j, "slip_rate_ratio");
  s.lag_mean = number(j, "lag_mean");
  s.lag_min = number(j, "lag_min");
  s.lag_max = number(j, "lag_max");
  // "window" in summaries written before it was named apart from events.window.
  s.window = number(j, j.contains("coincidence_window") ? "coincidence_window" : "window");
  s.coincident_fraction = number(j, "coincident_fraction");
  s.xcorr_peak = optional_number(j, "xcorr_peak");
  s.xcorr_lag = optional_number(j, "xcorr_lag");
  return s;
}

// A field that older summaries lack or that is null when not defined.
const nlohmann::json* present(const nlohmann::json& j, const char* name) {
  const auto it = j.find(name);
  return it == j.end() || it->is_null() ? nullptr : &*it;
}

// Prefixes the name of the enclosing field to what went wrong inside it.
template <class F>
auto inside(const char* name, F&& read) {
  try {
    return read();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string(name) + ": " + e.what());
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string(name) + ": " + e.what());
  }
}

}  // namespace

nlohmann::json to_json(const Summary& s) {
  nlohmann::json j = {
      {"mu", number_or_null(s.mu)},
      {"mu_error", number_or_null(s.mu_error)},
      {"mu_error_from",
       s.mu_error_from.empty() ? nlohmann::json() : nlohmann::json(s.mu_error_from)},
      {"mu_whole_cycles", nullptr},
      {"F_f_spread", s.F_f_spread ? number_or_null(*s.F_f_spread) : nlohmann::json()},
      {"theta", s.theta},
      {"F_N", s.F_N},
      {"contacts", s.contacts},
      {"t_end", s.t_end},
      {"average_from", s.average_from},
      {"average_from_auto", s.average_auto},
      {"window_samples", s.window_samples},
      {"wall_seconds", s.wall_seconds},
      {"energy_residual", number_or_null(s.energy_residual)},
      {"energy_audit_bound", s.energy_audit_bound},
      {"energy_audit_allowance", number_or_null(s.energy_audit_allowance)},
      {"steady_sliding_mu", number_or_null(s.steady_sliding_mu)},
      {"solver", s.solver},
      {"solver_stats", s.solver_stats},
      {"provenance", {{"git_commit", s.git_commit}, {"sundials_version", s.sundials_version}}},
      {"case", s.case_json},
  };
  if (!s.segments.empty()) {
    auto& segments = j["provenance"]["segments"] = nlohmann::json::array();
    for (const auto& seg : s.segments)
      segments.push_back({{"from", seg.from}, {"git_commit", seg.git_commit}});
  }
  if (const auto& r = s.regime)
    j["regime"] = {{"kind", to_string(r->kind)},
                   {"mu_trusted", r->mu_trusted()},
                   {"drift", number_or_null(r->drift)},
                   {"trend_share", number_or_null(r->trend_share)},
                   {"transient_ends", number_or_null(r->transient_ends)},
                   {"fix", r->mu_trusted() ? nlohmann::json() : nlohmann::json(regime_fix(s))}};
  auto& slips = j["block_slips"] = nlohmann::json::array();
  for (const auto& b : s.block_slips)
    slips.push_back({{"onset", b.onset}, {"end", b.end}, {"drop", b.drop}});
  if (const auto& c = s.mu_whole_cycles)
    j["mu_whole_cycles"] = {
        {"mu", c->mu}, {"error", number_or_null(c->error)}, {"from", c->from},
        {"to", c->to}, {"block_slips", c->block_slips},     {"period", number_or_null(c->period)}};
  if (const auto& e = s.events) {
    nlohmann::json per_contact = nlohmann::json::array();
    for (const auto& c : e->per_contact) per_contact.push_back(to_json(c));
    j["events"] = {{"count", e->count},
                   {"window", {e->window_from, e->window_to}},
                   {"per_contact", per_contact}};
  }
  if (s.synchronization) j["synchronization"] = to_json(*s.synchronization);
  j["warnings"] = nlohmann::json::array();
  for (const auto& w : s.warnings) j["warnings"].push_back({{"about", w.about}, {"text", w.text}});
  return j;
}

Summary summary_from_json(const nlohmann::json& j) {
  Summary s;
  s.mu = number(j, "mu");
  // Older summaries have no error bar, no window count, no "auto".
  s.mu_error = j.contains("mu_error") ? number(j, "mu_error") : std::nan("");
  if (const auto* from = present(j, "mu_error_from")) s.mu_error_from = from->get<std::string>();
  if (const auto* a = present(j, "average_from_auto")) s.average_auto = a->get<bool>();
  s.window_samples =
      j.contains("window_samples") ? static_cast<long>(number(j, "window_samples")) : 0;
  s.theta = number(j, "theta");
  s.F_N = number(j, "F_N");
  s.contacts = static_cast<long>(number(j, "contacts"));
  s.t_end = number(j, "t_end");
  s.average_from = number(j, "average_from");
  s.wall_seconds = number(j, "wall_seconds");
  s.energy_residual = number(j, "energy_residual");
  s.energy_audit_bound = number(j, "energy_audit_bound");
  // Older summaries have none: no allowance was reported then.
  s.energy_audit_allowance =
      j.contains("energy_audit_allowance") ? number(j, "energy_audit_allowance") : 0.0;
  s.steady_sliding_mu = number(j, "steady_sliding_mu");
  s.solver = field(j, "solver");
  s.solver_stats =
      inside("solver_stats", [&] { return field(j, "solver_stats").get<SolverStats>(); });
  const auto& provenance = field(j, "provenance");
  inside("provenance", [&] {
    s.git_commit = field(provenance, "git_commit").get<std::string>();
    s.sundials_version = field(provenance, "sundials_version").get<std::string>();
    if (const auto* segments = present(provenance, "segments"))  // absent before restarts kept them
      for (const auto& seg : *segments)
        s.segments.push_back({number(seg, "from"), field(seg, "git_commit").get<std::string>()});
    return 0;
  });
  s.case_json = field(j, "case");
  if (const auto* c = present(j, "mu_whole_cycles"))
    s.mu_whole_cycles = inside("mu_whole_cycles", [&] {
      // Before block slips were found, cycles were crossings of the mean:
      // such a summary has no block_slips, period or error (0, NaN, NaN).
      WholeCycleMu cycles{number(*c, "mu"), number(*c, "from"), number(*c, "to"), 0,
                          std::nan(""),     std::nan("")};
      if (c->contains("block_slips")) {
        cycles.block_slips = static_cast<long>(number(*c, "block_slips"));
        cycles.period = number(*c, "period");
        cycles.error = number(*c, "error");
      }
      return cycles;
    });
  if (const auto* slips = present(j, "block_slips"))  // absent before block slips were found
    for (const auto& b : *slips)
      s.block_slips.push_back(inside("block_slips", [&] {
        return BlockSlip{number(b, "onset"), number(b, "end"), number(b, "drop")};
      }));
  if (const auto* r = present(j, "regime"))  // absent before windows were judged
    s.regime = inside("regime", [&] {
      WindowRegime regime;
      const auto kind = field(*r, "kind").get<std::string>();
      bool known = false;
      for (Regime k : {Regime::stick_slip, Regime::steady_sliding, Regime::loading,
                       Regime::unsettled, Regime::undersampled, Regime::not_driven})
        if (kind == to_string(k)) regime.kind = k, known = true;
      if (!known) throw std::invalid_argument("\"kind\": no regime \"" + kind + "\"");
      regime.drift = number(*r, "drift");
      regime.trend_share = number(*r, "trend_share");
      regime.transient_ends =
          r->contains("transient_ends") ? number(*r, "transient_ends") : std::nan("");
      return regime;
    });
  if (const auto* f = present(j, "F_f_spread")) {
    if (!f->is_number()) throw std::invalid_argument("\"F_f_spread\" is not a number");
    s.F_f_spread = f->get<double>();
  }
  if (const auto* e = present(j, "events"))
    s.events = inside("events", [&] {
      EventSummary events;
      events.count = static_cast<long>(number(*e, "count"));
      const auto& window = field(*e, "window");
      events.window_from = window.at(0).get<double>();
      events.window_to = window.at(1).get<double>();
      for (const auto& c : field(*e, "per_contact"))
        events.per_contact.push_back(contact_statistics_from_json(c));
      return events;
    });
  if (const auto* warnings = present(j, "warnings"))  // absent before summaries had them
    for (const auto& w : *warnings)
      s.warnings.push_back(inside("warnings", [&] {
        return SummaryWarning{field(w, "about").get<std::string>(),
                              field(w, "text").get<std::string>()};
      }));
  if (const auto* sync = present(j, "synchronization"))
    s.synchronization = inside("synchronization", [&] { return synchronization_from_json(*sync); });
  return s;
}

std::string mu_text(const Summary& s) {
  char text[160];
  if (std::isfinite(s.mu_error))
    std::snprintf(text, sizeof text, "%.6f ± %.2g", s.mu, s.mu_error);
  else
    std::snprintf(text, sizeof text, "%.6f", s.mu);
  std::string out = text;
  std::snprintf(text, sizeof text, " over [%.4g, %.4g] s%s", s.average_from, s.t_end,
                s.average_auto ? " (auto)" : "");
  return out + text;
}

std::string regime_fix(const Summary& s) {
  if (!s.regime || s.regime->mu_trusted()) return {};
  const WindowRegime& r = *s.regime;
  char text[400];
  switch (r.kind) {
    case Regime::not_driven:
      return "this drive cannot slide: drive.velocity is 0; set it > 0";
    case Regime::undersampled:
      if (const auto* output = present(s.case_json, "output");
          output && output->contains("interval") && !s.mu_whole_cycles) {
        const double interval = (*output)["interval"].get<double>();
        if (s.t_end - s.average_from < static_cast<double>(kMinSamples) * interval) {
          std::snprintf(text, sizeof text,
                        "a longer window (run.t_end) or a finer output.interval: the window is "
                        "shorter than %ld output intervals of %g s",
                        kMinSamples, interval);
          return text;
        }
      }
      std::snprintf(text, sizeof text,
                    "a finer output.interval: the window holds %ld sample%s of F_f%s",
                    s.window_samples, s.window_samples == 1 ? "" : "s",
                    s.mu_whole_cycles && s.mu_whole_cycles->period > 0
                        ? ", too few per block cycle to see its rise and fall"
                        : "");
      return text;
    case Regime::loading:
      if (!std::isnan(r.transient_ends)) {
        std::snprintf(text, sizeof text,
                      "a later run.average_from: the loading transient ends at %.4g s; start the "
                      "average there or later, or set run.average_from = \"auto\"%s",
                      r.transient_ends,
                      r.transient_ends >= s.t_end * 0.5 ? ", with a longer run.t_end" : "");
        return text;
      }
      return "a longer run.t_end: F_f is still on its loading ramp at the end of the run, no "
             "block slip yet";
    case Regime::unsettled:
      if (!s.block_slips.empty())  // the run has block slips, the window too few of them
        return "a longer window (run.t_end, or an earlier run.average_from past the loading "
               "transient): it holds fewer than two block slips";
      return "a longer window (run.t_end, or an earlier run.average_from past the loading "
             "transient): it holds fewer than two block slips, and F_f is neither steady nor a "
             "ramp";
    default:
      return {};
  }
}

std::string mu_warning(const Summary& s) {
  if (!s.regime || s.regime->mu_trusted()) return {};
  char window[96];
  std::snprintf(window, sizeof window, "the averaging window [%.4g, %.4g] s", s.average_from,
                s.t_end);
  const std::string fix = "; the fix: " + regime_fix(s);
  const WindowRegime& r = *s.regime;
  switch (r.kind) {
    case Regime::not_driven:
      return "mu is not a friction coefficient: nothing slides" + fix;
    case Regime::undersampled:
      return "mu cannot be judged: " + std::string(window) + " is sampled too coarsely" + fix;
    case Regime::loading:
      if (!std::isnan(r.transient_ends))
        return "mu is not a friction coefficient: " + std::string(window) +
               " starts on the loading ramp from rest (F_f rising, no block slip yet), which "
               "biases mu low" +
               fix;
      {
        char rise[64];
        std::snprintf(rise, sizeof rise, "%.0f %%", 100 * r.drift);
        return "mu is not a friction coefficient: in " + std::string(window) +
               " F_f rises as a ramp (by " + rise +
               ") with no block slip, the block still loading" + fix;
      }
    default:
      return "mu is not a friction coefficient yet: " + std::string(window) +
             " holds no whole cycle of F_f and F_f is not steady" + fix;
  }
}

std::string tolerance_warning(double rtol) {
  if (!(rtol > kLooseRtol)) return {};
  char text[320];
  // Measured on cases/fig10b.toml (dirk): at 1e-4 one of contact 0's nine
  // slips split in two and onsets moved by up to 3.5e-6 s; at 1e-5, 1e-6 and
  // 1e-7 the same slips, μ within 5e-6.
  std::snprintf(text, sizeof text,
                "rtol = %g is looser than %g: slip counts and times may be wrong (on the "
                "paper's two-contact case rtol 1e-4 split a slip in two and moved onsets by "
                "3.5e-6 s); check them at rtol <= %g",
                rtol, kLooseRtol, kLooseRtol);
  return text;
}

std::vector<SummaryWarning> summary_warnings(const Summary& s, double rtol) {
  std::vector<SummaryWarning> out;
  if (std::string w = mu_warning(s); !w.empty()) out.push_back({"mu", std::move(w)});
  if (std::string w = tolerance_warning(rtol); !w.empty()) out.push_back({"rtol", std::move(w)});
  return out;
}

void write_summary(const std::filesystem::path& dir, const Summary& s) {
  write_json_atomically(dir / kSummaryFile, to_json(s));
}

std::optional<Summary> read_summary(const std::filesystem::path& dir) {
  const auto file = dir / kSummaryFile;
  std::ifstream in(file);
  if (!in) return std::nullopt;
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;  // cut short
  }
  try {
    return summary_from_json(j);
  } catch (const std::invalid_argument& e) {
    throw OutputError(file.string() + ": not a run summary: " + e.what());
  }
}

}  // namespace stickslip
