// stickslip._core: the C++ library as seen from Python. Thin on purpose: it
// reads and validates cases, runs them, and reads a run's tables back, all
// through the library the command line uses; the Python package
// (python/stickslip/__init__.py) turns what it returns into the user's
// objects (Case, Run, numpy arrays, a DataFrame).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/integrate/errors.hpp"
#include "stickslip/output/recorder.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/run.hpp"
#include "stickslip/sweep/sweep.hpp"
#include "stickslip/version.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

using namespace stickslip;

// Messages about a dict's keys start with the key: "drive.velocity: must be >= 0, got -1".
constexpr const char* kDictOrigin = "";

py::array_t<double> to_array(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

// Table `name` of the run in `dir` (either format) as [(column, values)].
py::list read_columns(const fs::path& dir, const std::string& name) {
  py::list out;
  for (const auto& [column, values] : read_run_columns(dir, name))
    out.append(py::make_tuple(column, to_array(values)));
  return out;
}

py::dict read_events(const fs::path& dir) {
  const std::vector<Event> events = read_run_events(dir);
  const auto n = static_cast<py::ssize_t>(events.size());
  py::array_t<double> t(n), speed(n), force(n);
  py::array_t<long> contact(n);
  py::list kind;
  for (py::ssize_t i = 0; i < n; ++i) {
    const Event& e = events[static_cast<std::size_t>(i)];
    t.mutable_at(i) = e.t;
    contact.mutable_at(i) = e.contact;
    speed.mutable_at(i) = e.speed;
    force.mutable_at(i) = e.force;
    kind.append(to_string(e.kind));
  }
  py::dict d;
  d["t"] = t;
  d["contact"] = contact;
  d["kind"] = kind;
  d["speed"] = speed;
  d["force"] = force;
  return d;
}

// Runs the case; returns summary.json's text, or on SIGINT/SIGTERM
// ("interrupted", signal, t). The GIL is released for the run. While it goes,
// SIGINT and SIGTERM stop it at its next output time or, between output times,
// within a poll interval of steps (a few hundred), as on the command line,
// and with it every other run of the process (runs in threads). `progress`,
// unless None, is called with (t, steps) at the first output time, then
// twice a second at most (with the GIL; an exception it raises is dropped: a
// progress bar must not stop a run).
py::object run(const Case& c, const fs::path& out, bool overwrite, bool restart, bool any_version,
               bool quiet, const py::object& progress) {
  RunOptions options;
  options.out_dir = out;
  options.overwrite = overwrite;
  options.restart = restart;
  options.any_version = any_version;
  options.quiet = quiet;
  if (!progress.is_none()) {
    // A pointer, not a copy: the options are copied and destroyed without
    // the GIL, and a py::object must not be.
    const py::object* callback = &progress;
    options.on_progress = [callback](double t, long steps) {
      py::gil_scoped_acquire gil;
      try {
        (*callback)(t, steps);
      } catch (py::error_already_set& e) {
        e.discard_as_unraisable("stickslip progress callback");
      }
    };
  }
  std::optional<Interrupted> stopped;
  Summary summary;
  {
    py::gil_scoped_release release;
    const ScopedStopHandlers handlers;
    try {
      summary = run_case(c, options);
    } catch (const Interrupted& stop) {
      stopped = stop;
    }
  }
  if (stopped) return py::make_tuple("interrupted", stopped->signal, stopped->t);
  return py::str(to_json(summary).dump());
}

// `stickslip sweep` without MPI or shards: this process's points not yet
// finished, `jobs` at a time, then sweep.csv and sweep_summary.csv. Returns
// the counts and the signal that stopped it (0 if none; run_sweep handles
// SIGINT and SIGTERM itself, passing them to its points).
py::dict sweep(const fs::path& file, const fs::path& out, int jobs,
               const std::vector<std::string>& sets, bool overwrite, bool any_version,
               const fs::path& executable, bool progress) {
  const Sweep s = read_sweep(file, sets);
  const auto points = sweep_points(s);
  SweepOptions options;
  options.out_dir = out.empty() ? fs::path("out") / s.source.stem() : out;
  options.jobs =
      jobs > 0 ? jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  options.overwrite = overwrite;
  options.any_version = any_version;
  options.executable = executable;
  std::error_code ec;
  fs::create_directories(options.out_dir, ec);
  if (ec)
    throw OutputError(options.out_dir.string() +
                      ": cannot create output directory: " + ec.message());
  SweepOutcome outcome;
  std::size_t finished = 0;
  {
    py::gil_scoped_release release;
    std::ostream silent(nullptr);  // a stream without a buffer writes nothing
    outcome = run_sweep(s, points, options, progress ? std::cout : silent);
    std::cout.flush();
    finished = write_sweep_tables(s, points, options.out_dir, options.any_version);
  }
  py::dict d;
  d["out"] = options.out_dir;
  d["points"] = outcome.points;
  d["skipped"] = outcome.skipped;
  d["ran"] = outcome.ran;
  d["failed"] = outcome.failed;
  d["finished"] = finished;
  d["interrupted_by"] = outcome.interrupted_by;
  return d;
}

// A message of the library that names a command-line flag, as run() spells
// it: --overwrite is overwrite=True, --restart restart=True.
std::string in_python_words(std::string text) {
  for (const auto& [flag, keyword] :
       {std::pair<std::string, std::string>{"--overwrite", "overwrite=True"},
        {"--restart", "restart=True"},
        {"--any-version", "any_version=True"}})
    for (std::size_t at = text.find(flag); at != std::string::npos;
         at = text.find(flag, at + keyword.size()))
      text.replace(at, flag.size(), keyword);
  return text;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "stickslip's C++ library; use the package `stickslip`, not this module";
  m.attr("version") = kVersion;
  m.attr("git_commit") = kGitCommit;

  // Python exceptions with the command line's meaning: CaseError and
  // OutputError are bad input (exit code 2 there), IntegrationError a run
  // that failed.
  static py::exception<CaseError> case_error(m, "CaseError", PyExc_ValueError);
  static py::exception<OutputError> output_error(m, "OutputError", PyExc_OSError);
  static py::exception<IntegrationError> integration_error(m, "IntegrationError",
                                                           PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const CaseError& e) {
      case_error(e.what());
    } catch (const OutputError& e) {
      output_error(in_python_words(e.what()).c_str());
    } catch (const IntegrationError& e) {
      integration_error(e.what());
    }
  });

  py::class_<Case>(m, "Case", "a validated case (the package's Case wraps it)")
      .def("to_json", [](const Case& c) { return to_json(c).dump(); })
      .def_property_readonly("source", [](const Case& c) { return c.source; })
      .def_property_readonly(
          "coverage", [](const Case& c) { return realized_coverage(c.lattice, c.interface); },
          "θ as placed (an explicit contacts list's, not interface.coverage)")
      .def("output_dir", [](const Case& c) { return output_dir_for(c, {}); });

  m.def(
      "read_case",
      [](const fs::path& file, const std::vector<std::string>& overrides) {
        return read_case(file, overrides, kDictOrigin);
      },
      py::arg("file"), py::arg("overrides"));
  m.def(
      "parse_case",
      [](const std::string& text, const fs::path& source,
         const std::vector<std::string>& overrides) {
        return parse_case(text, source, overrides, kDictOrigin);
      },
      py::arg("text"), py::arg("source"), py::arg("overrides"));
  m.def("to_toml", [](const Case& c) { return to_toml(c); });
  m.def("recorder_tables", &recorder_tables);
  // traces' columns vx_<id>, vy_<id>, named where the recorder names them.
  m.def("member_column", &member_column, py::arg("dataset"), py::arg("member"));
  m.def("column_member", &column_member, py::arg("name"), py::arg("dataset"));
  m.attr("sweep_file") = kSweepFile;
  m.def("case_key_problem", [](const std::string& key) { return case_key_problem(key); });

  m.def("run", &run, py::arg("case"), py::arg("out"), py::arg("overwrite"), py::arg("restart"),
        py::arg("any_version"), py::arg("quiet"), py::arg("progress") = py::none());
  m.def("sweep", &sweep, py::arg("file"), py::arg("out"), py::arg("jobs"), py::arg("sets"),
        py::arg("overwrite"), py::arg("any_version"), py::arg("executable"), py::arg("progress"));

  m.def("has_table", &has_run_table, py::arg("dir"), py::arg("name"));
  m.def("read_columns", &read_columns, py::arg("dir"), py::arg("name"));
  m.def("read_events", &read_events, py::arg("dir"));
  m.def(
      "read_summary",
      [](const fs::path& dir) -> py::object {
        const auto s = read_summary(dir);
        if (!s) return py::none();
        return py::str(to_json(*s).dump());
      },
      py::arg("dir"));
}
