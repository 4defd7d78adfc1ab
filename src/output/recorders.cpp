// Every output of a run, one Recorder each (output/recorder.hpp), and the
// registry that says which table each writes and when the case asks for it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "stickslip/case/methods.hpp"
#include "stickslip/core/cycles.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/output/recorder.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

namespace fs = std::filesystem;

// A table that a restart continues: cut back to the checkpoint's time and
// appended to, or created.
std::unique_ptr<Table> open_table(const RecorderSetup& s, const TableSpec& spec) {
  return s.resume_at ? s.tables.resume(spec, *s.resume_at) : s.tables.create(spec);
}

// The time column of every table; digits as it has always been printed.
Column time_column(int digits = 12) {
  return {.name = "t", .unit = "s", .digits = digits};
}

Column real(std::string name, std::string unit, int digits = 10) {
  return {.name = std::move(name), .unit = std::move(unit), .digits = digits};
}

Column integer(std::string name) {
  return {.name = std::move(name), .type = ColumnType::integer};
}

// contacts: where the contacts are (a patch's corner) and their v*, written once.
class ContactsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kContacts;
  explicit ContactsRecorder(const RecorderSetup& s) {
    if (s.resume_at) return;  // written by the first run
    const auto table = s.tables.create(
        {kTable, {integer("id"), integer("ix"), integer("iy"), real("v_star", "m/s", kExact)}});
    const auto& contacts = s.system.contact_set().contacts();
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const double row[4] = {double(i), double(contacts[i].ix), double(contacts[i].iy),
                             contacts[i].v_star};
      table->append(row);
    }
    table->flush();
  }
};

// friction: F_f and F_f/F_N at the output times. At the end, from these
// samples, kept in memory as they are recorded (so it costs nothing during
// the run): what F_f does in the averaging window, μ over whole cycles and
// the error of the mean (core/cycles.hpp). With run.average_from = "auto"
// the window's start is found there too, and μ is the friction impulse from
// it: the table then has the impulse ∫F_f dt as a column, which a restart
// reads back with the samples before its checkpoint (the only time the table
// is read).
class FrictionRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kFriction;
  static constexpr const char* kForce = "F_f";
  static constexpr const char* kImpulse = "impulse";
  explicit FrictionRecorder(const RecorderSetup& s)
      : system_(s.system),
        table_(open_table(s, spec(s.c.run.average_auto))),
        normal_force_(s.system.normal_force()),
        average_from_(s.c.run.average_from),
        average_auto_(s.c.run.average_auto),
        driven_(s.c.drive.velocity > 0),
        impulse_index_(
            static_cast<std::size_t>(s.system.quadrature_index(System::friction_impulse))) {
    if (!s.resume_at) return;
    table_->flush();  // the cut back reaches the file before it is read
    const TraceTable before = read_run_table(s.dir, kTable);
    t_ = before.t;
    friction_ = before.column(kForce);
    if (average_auto_) impulse_ = before.column(kImpulse);
  }
  void record(double t, std::span<const double> y) override {
    const double ff = system_.friction_force(t, y);
    const double row[4] = {t, ff, ff / normal_force_, y[impulse_index_]};
    table_->append(std::span<const double>(row, average_auto_ ? 4 : 3));
    t_.push_back(t);
    friction_.push_back(ff);
    if (average_auto_) impulse_.push_back(y[impulse_index_]);
  }
  void flush() override { table_->flush(); }
  void finish(double t_end, std::span<const double> y, Summary& summary) override {
    if (average_auto_ && !t_.empty()) {
      // The window starts at an output time, where the impulse is known exactly.
      const double from = settled_from(t_, friction_);
      const auto k =
          static_cast<std::size_t>(std::lower_bound(t_.begin(), t_.end(), from) - t_.begin());
      if (k < t_.size() && t_[k] < t_end) {
        average_from_ = t_[k];
        summary.average_from = average_from_;
        summary.mu = (y[impulse_index_] - impulse_[k]) / ((t_end - average_from_) * normal_force_);
      }
    }
    const FrictionWindow w = analyse_window(t_, friction_, average_from_, driven_);
    summary.average_auto = average_auto_;
    summary.mu_error = w.error / normal_force_;
    summary.mu_error_from = w.error_from;
    summary.window_samples = w.samples;
    if (w.samples >= 2) summary.F_f_spread = w.spread;
    const CycleMean& c = w.cycles;
    if (c.block_slips >= 2)
      summary.mu_whole_cycles = WholeCycleMu{
          c.mean / normal_force_, c.from, c.to, c.block_slips, c.period, c.error / normal_force_};
    summary.regime = w.regime;
    summary.block_slips = w.block_slips;
  }

 private:
  static TableSpec spec(bool with_impulse) {
    TableSpec spec{kTable, {time_column(), real(kForce, "N"), real("mu_inst", "1")}};
    if (with_impulse) spec.columns.push_back(real(kImpulse, "N s", kExact));
    return spec;
  }
  const System& system_;
  std::unique_ptr<Table> table_;
  double normal_force_, average_from_;
  bool average_auto_, driven_;
  std::size_t impulse_index_;
  std::vector<double> t_, friction_, impulse_;  // every sample: t [s], F_f [N], ∫F_f dt [N s]
};

// traces: the traced contacts' in-plane velocities at the output times (in
// CSV vx_<id>, vy_<id> per contact (member_column); in HDF5 vx and vy as
// [time × contact]).
class TracesRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kTraces;
  static constexpr const char* kVx = "vx";
  static constexpr const char* kVy = "vy";
  explicit TracesRecorder(const RecorderSetup& s)
      : system_(s.system), traced_(s.traced), table_(open_table(s, spec(s.traced))) {
    row_.resize(1 + 2 * traced_.size());
  }
  void record(double t, std::span<const double> y) override {
    row_[0] = t;
    for (std::size_t k = 0; k < traced_.size(); ++k) {
      const auto v =
          system_.contact_set().contact_velocity(static_cast<std::size_t>(traced_[k]), y);
      row_[1 + 2 * k] = v[0];
      row_[2 + 2 * k] = v[1];
    }
    table_->append(row_);
  }
  void flush() override { table_->flush(); }

 private:
  static TableSpec spec(const std::vector<int>& traced) {
    TableSpec spec{kTable, {time_column()}, "contact", traced};
    for (std::size_t k = 0; k < traced.size(); ++k)
      for (const char* axis : {kVx, kVy}) {
        Column c = real(member_column(axis, traced[k]), "m/s");
        c.dataset = axis;
        c.member = static_cast<int>(k);
        spec.columns.push_back(std::move(c));
      }
    return spec;
  }
  const System& system_;
  std::vector<int> traced_;
  std::unique_ptr<Table> table_;
  std::vector<double> row_;
};

// Elastic travel time between two bottom sites at the transverse sound speed,
// over the shortest periodic separation: the default coincidence window.
double travel_time(const System& s, const Contact& a, const Contact& b) {
  auto wrap = [](int d, int n) {
    d = std::abs(d) % n;
    return std::min(d, n - d);
  };
  const double dx = wrap(a.ix - b.ix, s.nx()), dy = wrap(a.iy - b.iy, s.ny());
  return std::hypot(dx, dy) * s.spacing() / std::sqrt(s.g1());
}

// events: every stick/slip transition of the watched contacts. At the
// end, their statistics over the averaging window and, when exactly two are
// watched, their synchronization (with the cross-correlation of their
// x-velocities when both are traced, kept in memory for it).
class EventsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kEvents;
  explicit EventsRecorder(const RecorderSetup& s)
      : system_(s.system),
        watched_(s.watched),
        table_(open_table(s, {kTable,
                              {time_column(15),
                               integer("contact"),
                               {.name = "kind",
                                .type = ColumnType::label,
                                .labels = {std::string(to_string(EventKind::slip)),
                                           std::string(to_string(EventKind::stick))}},
                               real("speed", "m/s"),
                               real("force", "N")}})) {
    // The label column holds the EventKind's number.
    static_assert(static_cast<int>(EventKind::slip) == 0 &&
                  static_cast<int>(EventKind::stick) == 1);
    for (std::size_t i = 0; i < s.system.contact_set().contacts().size(); ++i)
      slipping_at_start_.push_back(s.system.contact_set().slipping(i, s.initial_state));
    if (s.resume_at) {
      table_->flush();  // the cut back reaches the file before it is read
      events_ = read_run_events(s.dir);
    }
    if (watched_.size() != 2) return;
    pair_ = {watched_[0], watched_[1]};
    auto traced = [&](int id) {
      return std::find(s.traced.begin(), s.traced.end(), id) != s.traced.end();
    };
    pair_traced_ = traced(pair_->first) && traced(pair_->second);
    if (!pair_traced_ || !s.resume_at) return;
    // The traces up to the checkpoint, as TracesRecorder wrote them (whether
    // or not it has cut its table back yet: rows after the checkpoint are left out).
    const TraceTable table = read_run_table(s.dir, TracesRecorder::kTable);
    const auto rows = static_cast<std::size_t>(
        std::upper_bound(table.t.begin(), table.t.end(), *s.resume_at) - table.t.begin());
    auto column = [&](int id) {
      const auto& values = table.column(member_column(TracesRecorder::kVx, id));
      return std::vector<double>(values.begin(),
                                 values.begin() + static_cast<std::ptrdiff_t>(rows));
    };
    pair_t_.assign(table.t.begin(), table.t.begin() + static_cast<std::ptrdiff_t>(rows));
    pair_va_ = column(pair_->first);
    pair_vb_ = column(pair_->second);
  }
  void record(double t, std::span<const double> y) override {
    if (!pair_traced_) return;
    pair_t_.push_back(t);
    pair_va_.push_back(
        system_.contact_set().contact_velocity(static_cast<std::size_t>(pair_->first), y)[0]);
    pair_vb_.push_back(
        system_.contact_set().contact_velocity(static_cast<std::size_t>(pair_->second), y)[0]);
  }
  void event(const Event& e, std::span<const double>) override {
    events_.push_back(e);
    const double row[5] = {e.t, double(e.contact), double(static_cast<int>(e.kind)), e.speed,
                           e.force};
    table_->append(row);
  }
  void flush() override { table_->flush(); }
  void finish(double t_end, std::span<const double>, Summary& summary) override {
    // The window μ's: with run.average_from = "auto" the friction recorder,
    // finished before this one (kRecorders' order), has found its start.
    const double t_avg = summary.average_from;
    EventSummary events{static_cast<long>(events_.size()), t_avg, t_end, {}};
    for (int id : watched_)
      events.per_contact.push_back(contact_statistics(
          events_, id, slipping_at_start_[static_cast<std::size_t>(id)], t_avg, t_end));
    summary.events = std::move(events);
    if (!pair_) return;
    const auto& contacts = system_.contact_set().contacts();
    const double window = travel_time(system_, contacts[static_cast<std::size_t>(pair_->first)],
                                      contacts[static_cast<std::size_t>(pair_->second)]);
    // Only the averaging window is correlated: the start from rest is a transient.
    summary.synchronization = synchronization(events_, pair_->first, pair_->second, window, t_avg,
                                              t_end, pair_t_, pair_va_, pair_vb_);
  }

 private:
  const System& system_;
  std::vector<int> watched_;
  std::unique_ptr<Table> table_;
  std::vector<Event> events_;
  std::vector<bool> slipping_at_start_;
  std::optional<std::pair<int, int>> pair_;
  bool pair_traced_ = false;
  std::vector<double> pair_t_, pair_va_, pair_vb_;
};

// slips: the catalogue, one row per slip of a watched contact, from its slip
// event to its next stick event, written at the stick: when and how long,
// how far the contact moved, how fast at most, and how much the load on it
// and the block's friction fell (docs/USAGE.md, "slips.csv"). A slip already under
// way at t = 0 (a run started sliding) or still going at t_end has no row.
// The peak speed is the largest of the contact's speed at the two events, at
// every state the integrator returned in between (output times, stops, other
// contacts' events) and at the integrator's own samples of it
// (Integrator::peak_speeds): all points of the computed solution, so never
// above its maximum. A slip under way at a checkpoint is saved in it (its
// start and peak so far cannot be read back from the table).
class SlipsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kSlips;
  explicit SlipsRecorder(const RecorderSetup& s)
      : system_(s.system),
        watched_(s.watched),
        index_(s.system.contact_set().contacts().size(), -1),
        open_(s.watched.size()),
        acc_(static_cast<std::size_t>(3 * s.system.num_nodes())),
        // A run begun by code older than this table (continued with
        // --any-version) has none: its catalogue starts at the restart.
        table_(s.resume_at && !has_run_table(s.dir, kTable) ? s.tables.create(spec())
                                                            : open_table(s, spec())) {
    for (std::size_t k = 0; k < watched_.size(); ++k)
      index_[static_cast<std::size_t>(watched_[k])] = static_cast<int>(k);
    if (!s.resume_at) return;
    const auto saved = s.saved.find(kTable);
    if (saved == s.saved.end()) return;  // an older checkpoint: the slips under way are lost
    for (const auto& o : *saved) {
      const int k = index_.at(o.at("contact").get<std::size_t>());
      if (k < 0) continue;
      auto number = [](const nlohmann::json& x) { return x.get<double>(); };
      open_[static_cast<std::size_t>(k)] = Start{number(o.at("t")),
                                                 {number(o.at("u").at(0)), number(o.at("u").at(1))},
                                                 number(o.at("load")),
                                                 number(o.at("F_f")),
                                                 number(o.at("peak"))};
    }
  }
  void reached(double, std::span<const double> y, std::span<const double> peaks) override {
    have_acc_ = false;  // a new state
    for (std::size_t k = 0; k < open_.size(); ++k) {
      if (!open_[k]) continue;
      const double speed =
          system_.contact_set().contact_speed(static_cast<std::size_t>(watched_[k]), y);
      open_[k]->peak = std::max({open_[k]->peak, peaks[k], speed});
    }
  }
  void event(const Event& e, std::span<const double> y) override {
    const int k = index_.at(static_cast<std::size_t>(e.contact));
    if (k < 0) return;
    auto& open = open_[static_cast<std::size_t>(k)];
    if (e.kind == EventKind::slip) {
      if (!open) open = at(e, y);  // (a repeated slip event keeps the first)
      return;
    }
    if (!open) return;  // under way before the run (or a lost checkpoint) began
    const Start& start = *open;
    const Start now = at(e, y);
    const double row[12] = {e.t,
                            double(e.contact),
                            start.t,
                            e.t - start.t,
                            std::hypot(now.u[0] - start.u[0], now.u[1] - start.u[1]),
                            std::max(start.peak, e.speed),
                            start.load,
                            now.load,
                            start.load - now.load,
                            start.F_f,
                            now.F_f,
                            start.F_f - now.F_f};
    table_->append(row);
    open.reset();
  }
  void flush() override { table_->flush(); }
  void save(nlohmann::json& saved) const override {
    nlohmann::json slips = nlohmann::json::array();
    for (std::size_t k = 0; k < open_.size(); ++k)
      if (const auto& o = open_[k])
        slips.push_back({{"contact", watched_[k]},
                         {"t", o->t},
                         {"u", {o->u[0], o->u[1]}},
                         {"load", o->load},
                         {"F_f", o->F_f},
                         {"peak", o->peak}});
    saved[kTable] = std::move(slips);
  }

 private:
  // A slip's start, and its peak speed so far.
  struct Start {
    double t;
    std::array<double, 2> u;  // the contact's in-plane displacement [m]
    double load, F_f;         // [N]
    double peak;              // [m/s]
  };
  static TableSpec spec() {
    // Rows come in the order the slips end: the end time first, as the time
    // a restart cuts the table back to.
    return {kTable,
            {{.name = "t_end", .unit = "s", .digits = 15},
             integer("contact"),
             {.name = "t_start", .unit = "s", .digits = 15},
             real("duration", "s"),
             real("slip", "m"),
             real("peak_speed", "m/s"),
             real("load_start", "N"),
             real("load_end", "N"),
             real("load_drop", "N"),
             real("F_f_start", "N"),
             real("F_f_end", "N"),
             real("F_f_drop", "N")}};
  }
  Start at(const Event& e, std::span<const double> y) {
    const auto i = static_cast<std::size_t>(e.contact);
    if (!have_acc_) {  // one lattice evaluation for all events at this state
      const auto n3 = acc_.size();
      system_.lattice_accelerations(e.t, y.subspan(0, n3), y.subspan(n3, n3), acc_);
      have_acc_ = true;
    }
    return {e.t, system_.contact_set().contact_displacement(i, y),
            system_.contact_set().contact_load(i, acc_), system_.friction_force(e.t, y), e.speed};
  }

  const System& system_;
  std::vector<int> watched_;
  std::vector<int> index_;  // contact id -> its index in watched_, −1 if not watched
  std::vector<std::optional<Start>> open_;  // per watched contact: its slip under way
  std::vector<double> acc_;                 // lattice accelerations at the last state
  bool have_acc_ = false;
  std::unique_ptr<Table> table_;
};

// steps: every accepted step's size, error estimate and h λ, and the
// columns its stepper declares (step_columns: with method = "multirate" how
// many contacts the step left to their own sub-steps, and those sub-steps).
class StepsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kSteps;
  explicit StepsRecorder(const RecorderSetup& s)
      : own_(step_columns(s.method)), table_(open_table(s, schema())) {}
  bool wants_steps() const override { return true; }
  void step(const StepRecord& r) override {
    std::array<double, 4 + kMaxStepColumns> row{r.t, r.h, r.error, r.h_lambda};
    std::copy(r.method_values.begin(), r.method_values.begin() + own_.size(), row.begin() + 4);
    table_->append(std::span(row.data(), 4 + own_.size()));
  }
  void flush() override { table_->flush(); }

 private:
  TableSpec schema() const {
    TableSpec t{kTable, {time_column(), real("h", "s"), real("error", "1"), real("h_lambda", "1")}};
    for (const StepColumn& c : own_)
      t.columns.push_back(c.integer ? integer(c.name) : real(c.name, c.unit));
    return t;
  }

  std::span<const StepColumn> own_;
  std::unique_ptr<Table> table_;
};

// attempts: every attempt at a coarse step of a stepper whose attempts are
// this project's own (multirate, multirate_integrator.hpp): its start and
// size, its fast contacts, the coupling pass its verdict came in, its
// weighted error, coupling and miss, the verdict, and the state component
// that decided it (kind and node; "none" and −1 where none did).
class AttemptsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kAttempts;
  explicit AttemptsRecorder(const RecorderSetup& s)
      : system_(s.system), table_(open_table(s, schema())) {}
  bool wants_attempts() const override { return true; }
  void attempt(const AttemptRecord& r) override {
    // "none" (the last kind) and −1 where no component decided the verdict.
    const System::Component c = r.worst >= 0
                                    ? system_.component(r.worst)
                                    : System::Component{static_cast<int>(std::size(kKinds)) - 1};
    const double row[12] = {r.t,
                            r.h,
                            static_cast<double>(r.fast_contacts),
                            static_cast<double>(r.coupling_pass),
                            r.error,
                            r.coupling,
                            r.miss,
                            static_cast<double>(r.verdict),
                            static_cast<double>(c.kind),
                            static_cast<double>(c.ix),
                            static_cast<double>(c.iy),
                            static_cast<double>(c.iz)};
    table_->append(row);
  }
  void flush() override { table_->flush(); }

 private:
  // The worst component's kinds, System::Component's, and none.
  static constexpr const char* kKinds[] = {
      "u_x", "u_y", "u_z", "w_x", "w_y", "w_z", "work", "dissipated", "friction_impulse", "none"};
  static TableSpec schema() {
    Column verdict{.name = "verdict", .type = ColumnType::label};
    for (const char* name : AttemptRecord::kVerdictNames) verdict.labels.emplace_back(name);
    Column kind{.name = "worst", .type = ColumnType::label};
    for (const char* name : kKinds) kind.labels.emplace_back(name);
    return {kTable,
            {time_column(15), real("h", "s", kExact), integer("fast_contacts"),
             integer("coupling_pass"), real("error", "1"), real("coupling", "1"), real("miss", "1"),
             verdict, kind, integer("worst_ix"), integer("worst_iy"), integer("worst_iz")}};
  }
  const System& system_;
  std::unique_ptr<Table> table_;
};

// signals: the block's centre-of-mass velocity, the contacts' impulse and
// the acoustic signal, its second difference over the output times (docs/USAGE.md, "signals.csv").
class SignalsRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kSignals;
  static constexpr const char* kImpulse = "contact_impulse";
  // Exact digits: the impulse is differenced twice.
  explicit SignalsRecorder(const RecorderSetup& s)
      : system_(s.system),
        table_(open_table(s, {kTable,
                              {time_column(), real("block_velocity", "m/s", kExact),
                               real(kImpulse, "N s", kExact), real("acoustic", "N/s", kExact)}})) {
    if (!s.resume_at) return;
    // The last two rows' (t, impulse), to difference the next ones.
    table_->flush();  // the cut back reaches the file before it is read
    const TraceTable written = read_run_table(s.dir, kTable);
    const auto& impulses = written.column(kImpulse);
    for (std::size_t k = written.t.size() - std::min<std::size_t>(2, written.t.size());
         k < written.t.size(); ++k)
      last_.push_back({written.t[k], impulses[k]});
  }
  void record(double t, std::span<const double> y) override {
    const double impulse = system_.contact_impulse(t, y);
    double acoustic = std::nan("");
    if (last_.size() == 2) {
      const auto [t0, j0] = last_[0];
      const auto [t1, j1] = last_[1];
      acoustic = ((impulse - j1) / (t - t1) - (j1 - j0) / (t1 - t0)) / (0.5 * (t - t0));
      last_.erase(last_.begin());
    }
    last_.push_back({t, impulse});
    const double row[4] = {t, system_.block_velocity(y), impulse, acoustic};
    table_->append(row);
  }
  void flush() override { table_->flush(); }

 private:
  const System& system_;
  std::unique_ptr<Table> table_;
  std::vector<std::array<double, 2>> last_;
};

// final_state: every node's displacement and velocity at t_end, in digits that read back exactly,
// for comparing runs state by state (bench/work_precision.py).
class FinalStateRecorder final : public Recorder {
 public:
  static constexpr const char* kTable = run_table::kFinalState;
  explicit FinalStateRecorder(const RecorderSetup& s) : system_(s.system), tables_(s.tables) {}
  void finish(double t_end, std::span<const double> y, Summary&) override {
    TableSpec spec{kTable, {time_column(), integer("ix"), integer("iy"), integer("iz")}};
    for (const char* name : {"u_x", "u_y", "u_z"}) spec.columns.push_back(real(name, "m", kExact));
    for (const char* name : {"w_x", "w_y", "w_z"})
      spec.columns.push_back(real(name, "m/s", kExact));
    const auto state = tables_.create(spec);
    std::array<double, 10> row{};
    for (int iz = 0; iz < system_.nz(); ++iz)
      for (int iy = 0; iy < system_.ny(); ++iy)
        for (int ix = 0; ix < system_.nx(); ++ix) {
          const std::int64_t n = system_.node(ix, iy, iz);
          row = {t_end, double(ix), double(iy), double(iz)};
          for (int k = 0; k < 3; ++k) {
            row[4 + k] = y[static_cast<std::size_t>(system_.u_index(n, k))];
            row[7 + k] = y[static_cast<std::size_t>(system_.w_index(n, k))];
          }
          state->append(row);
        }
    state->flush();
  }

 private:
  const System& system_;
  TableStore& tables_;
};

// The registry: each output's table, and whether the case asks for it, made
// in this order (which no recorder depends on: a restart's read-backs take
// the rows up to the checkpoint, and a row cut off mid-write has no newline
// and is not read, csv_tables.cpp).
struct RecorderKind {
  const char* table;
  bool (*asked)(const RecorderSetup&);
  std::unique_ptr<Recorder> (*make)(const RecorderSetup&);
};

template <class R>
std::unique_ptr<Recorder> make(const RecorderSetup& s) {
  return std::make_unique<R>(s);
}

constexpr RecorderKind kRecorders[] = {
    {ContactsRecorder::kTable, [](const RecorderSetup&) { return true; }, make<ContactsRecorder>},
    {FrictionRecorder::kTable, [](const RecorderSetup&) { return true; }, make<FrictionRecorder>},
    {TracesRecorder::kTable, [](const RecorderSetup& s) { return !s.traced.empty(); },
     make<TracesRecorder>},
    {EventsRecorder::kTable, [](const RecorderSetup& s) { return !s.watched.empty(); },
     make<EventsRecorder>},
    {SlipsRecorder::kTable, [](const RecorderSetup& s) { return !s.watched.empty(); },
     make<SlipsRecorder>},
    {StepsRecorder::kTable, [](const RecorderSetup& s) { return s.c.output.steps; },
     make<StepsRecorder>},
    {AttemptsRecorder::kTable,
     [](const RecorderSetup& s) {
       return s.c.output.attempts && method_info(s.method).package == Package::own;
     },
     make<AttemptsRecorder>},
    {SignalsRecorder::kTable, [](const RecorderSetup& s) { return s.c.output.signals; },
     make<SignalsRecorder>},
    {FinalStateRecorder::kTable, [](const RecorderSetup& s) { return s.c.output.final_state; },
     make<FinalStateRecorder>},
};

}  // namespace

std::vector<int> selected_contacts(ContactSelection which, const std::vector<int>& ids,
                                   std::size_t contacts) {
  if (which == ContactSelection::list) return ids;
  std::vector<int> all;
  if (which == ContactSelection::all)
    for (std::size_t i = 0; i < contacts; ++i) all.push_back(static_cast<int>(i));
  return all;
}

std::vector<std::unique_ptr<Recorder>> make_recorders(const RecorderSetup& setup) {
  std::vector<std::unique_ptr<Recorder>> recorders;
  for (const auto& kind : kRecorders)
    if (kind.asked(setup)) recorders.push_back(kind.make(setup));
  return recorders;
}

std::vector<std::string> recorder_tables() {
  std::vector<std::string> tables;
  for (const auto& kind : kRecorders) tables.emplace_back(kind.table);
  return tables;
}

std::vector<std::string> recorder_files() {
  std::vector<std::string> files{kHdf5File};
  for (const auto& table : recorder_tables()) files.push_back(csv_file_name(table));
  return files;
}

}  // namespace stickslip
