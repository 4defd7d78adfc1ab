#pragma once
// The outputs of a run, each one Recorder: it opens its table (a CSV file or
// an HDF5 group, output/tables.hpp), records at the output times, at
// stick/slip events or at steps, flushes, cuts itself back to a checkpoint on
// a restart (reading back what it needs to continue, or taking what it saved
// in the checkpoint), and adds its part to summary.json when the run ends. The run loop
// (run/run.cpp) owns advancing, averaging, checkpoints and the energy-audit
// gate, and knows the outputs only through this interface. A new output is
// one class in src/output/recorders.cpp, its line in the registry there, and
// its case key.

#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/core/events.hpp"
#include "stickslip/integrate/step_record.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"

namespace stickslip {

// What a recorder is built from.
struct RecorderSetup {
  const Case& c;
  const System& system;
  // The method the run integrates with: the case's, or what "auto" chose
  // (never auto), so a table lays out what that method records.
  Method method;
  TableStore& tables;
  std::filesystem::path dir;              // where the tables are read back from
  std::span<const double> initial_state;  // at t = 0 (a restart's too)
  // A restart: continue every file from this time (rows after it are dropped).
  std::optional<double> resume_at;
  std::vector<int> traced;   // contact ids whose velocities [output] traces asks for
  std::vector<int> watched;  // contact ids whose events [output] events asks for
  // A restart: what the recorders saved in the checkpoint (Recorder::save),
  // an empty object if nothing (or the checkpoint predates it).
  nlohmann::json saved = nlohmann::json::object();
};

class Recorder {
 public:
  virtual ~Recorder() = default;
  // At every output time, the state there (also t = 0 in a fresh run).
  virtual void record(double /*t*/, std::span<const double> /*y*/) {}
  // With watched contacts, every time the integrator returns (an output
  // time, a stick/slip transition, a stop), before its events: the state
  // there and Integrator::peak_speeds, per watched contact the largest speed
  // it sampled since its previous return.
  virtual void reached(double /*t*/, std::span<const double> /*y*/,
                       std::span<const double> /*peak_speeds*/) {}
  // A watched contact slipped or stuck (root finding, in time order); y is
  // the state there.
  virtual void event(const Event& /*e*/, std::span<const double> /*y*/) {}
  // Only recorders that want them get every accepted step (it costs a callback per step).
  virtual bool wants_steps() const { return false; }
  virtual void step(const StepRecord& /*r*/) {}
  // Likewise every attempt at a step, where the stepper reports them
  // (IntegratorOptions::on_attempt).
  virtual bool wants_attempts() const { return false; }
  virtual void attempt(const AttemptRecord& /*r*/) {}
  // Everything recorded so far reaches the file (a crash or a checkpoint).
  virtual void flush() {}
  // A checkpoint: what a restart cannot read back from the tables, under
  // this recorder's own key of `saved` (RecorderSetup::saved on the restart).
  virtual void save(nlohmann::json& /*saved*/) const {}
  // The run reached t_end and passed the energy audit: final files, and
  // this output's part of summary.json. Called after flush().
  virtual void finish(double /*t_end*/, std::span<const double> /*y*/, Summary& /*summary*/) {}
};

// The contact ids a [output] traces / events selection names.
std::vector<int> selected_contacts(ContactSelection which, const std::vector<int>& ids,
                                   std::size_t contacts);

// The recorders the case asks for, their tables created (or, on a restart,
// cut back to resume_at and reopened for appending). OutputError if a table
// cannot be opened.
std::vector<std::unique_ptr<Recorder>> make_recorders(const RecorderSetup& setup);

// The name of every table a recorder may write (friction, traces, ...).
std::vector<std::string> recorder_tables();

// Every file a recorder may write, whatever the case asks for and in either
// format: a directory holding one holds results, and --overwrite removes them
// all (no stale traces.csv from an earlier run that traced).
std::vector<std::string> recorder_files();

}  // namespace stickslip
