// Every output of a run, one Recorder each (output/recorder.hpp), and the
// registry that says which file each writes and when the case asks for it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "stickslip/analysis/compare.hpp"
#include "stickslip/analysis/cycles.hpp"
#include "stickslip/output/recorder.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

namespace fs = std::filesystem;

// A CSV output that a restart continues: cut back to the checkpoint's time
// and appended to, or created with its header.
CsvWriter open_table(const RecorderSetup& s, const char* name,
                     const std::vector<std::string>& header) {
  const fs::path file = s.dir / name;
  if (!s.resume_at) return CsvWriter(file, header);
  keep_rows_up_to(file, *s.resume_at);
  return CsvWriter::append(file);
}

// contacts.csv: where the contacts are and their v*, written once.
class ContactsRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "contacts.csv";
  explicit ContactsRecorder(const RecorderSetup& s) {
    if (s.resume_at) return;  // written by the first run
    std::ofstream out(s.dir / kFile);
    if (!out) throw OutputError((s.dir / kFile).string() + ": cannot open for writing");
    out << "id,ix,iy,v_star\n";
    char line[96];
    const auto& contacts = s.system.contacts();
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      std::snprintf(line, sizeof line, "%zu,%d,%d,%.17g\n", i, contacts[i].ix, contacts[i].iy,
                    contacts[i].v_star);
      out << line;
    }
  }
};

// friction.csv: F_f and F_f/F_N at the output times. At the end, from these
// samples (so it costs nothing during the run): μ over whole cycles of F_f
// and F_f's relative spread (analysis/cycles.hpp).
class FrictionRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "friction.csv";
  explicit FrictionRecorder(const RecorderSetup& s)
      : system_(s.system),
        file_(s.dir / kFile),
        csv_(open_table(s, kFile, {"t", "F_f", "mu_inst"})),
        normal_force_(s.system.normal_force()),
        average_from_(s.c.run.average_from) {}
  void record(double t, std::span<const double> y) override {
    const double ff = system_.friction_force(t, y);
    const double row[2] = {ff, ff / normal_force_};
    csv_.row(t, row);
  }
  void flush() override { csv_.flush(); }
  void finish(double, std::span<const double>, Summary& summary) override {
    const TraceTable series = read_traces_csv(file_);  // t, F_f, mu_inst
    const auto& t = series.t;
    if (std::count_if(t.begin(), t.end(), [&](double ti) { return ti >= average_from_; }) < 2)
      return;
    const CycleMean cycles = whole_cycle_mean(t, series.values[0], average_from_);
    summary.mu_whole_cycles =
        WholeCycleMu{cycles.mean / normal_force_, cycles.from, cycles.to, cycles.crossings};
    summary.F_f_spread = relative_spread(t, series.values[0], average_from_);
  }

 private:
  const System& system_;
  fs::path file_;
  CsvWriter csv_;
  double normal_force_, average_from_;
};

// traces.csv: the traced contacts' in-plane velocities at the output times.
class TracesRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "traces.csv";
  explicit TracesRecorder(const RecorderSetup& s)
      : system_(s.system), traced_(s.traced), csv_(open_table(s, kFile, header(s.traced))) {
    row_.resize(2 * traced_.size());
  }
  void record(double t, std::span<const double> y) override {
    for (std::size_t k = 0; k < traced_.size(); ++k) {
      const auto v = system_.contact_velocity(static_cast<std::size_t>(traced_[k]), y);
      row_[2 * k] = v[0];
      row_[2 * k + 1] = v[1];
    }
    csv_.row(t, row_);
  }
  void flush() override { csv_.flush(); }

 private:
  static std::vector<std::string> header(const std::vector<int>& traced) {
    std::vector<std::string> h{"t"};
    for (int id : traced) {
      h.push_back("vx_" + std::to_string(id));
      h.push_back("vy_" + std::to_string(id));
    }
    return h;
  }
  const System& system_;
  std::vector<int> traced_;
  CsvWriter csv_;
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

// events.csv: every stick/slip transition of the watched contacts. At the
// end, their statistics over the averaging window and, when exactly two are
// watched, their synchronization (with the cross-correlation of their
// x-velocities when both are traced, kept in memory for it).
class EventsRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "events.csv";
  explicit EventsRecorder(const RecorderSetup& s)
      : system_(s.system),
        average_from_(s.c.run.average_from),
        watched_(s.watched),
        csv_(open_table(s, kFile, {"t", "contact", "kind", "speed", "force"})) {
    for (std::size_t i = 0; i < s.system.contacts().size(); ++i)
      slipping_at_start_.push_back(s.system.slipping(i, s.initial_state));
    if (s.resume_at) events_ = read_events_csv(s.dir / kFile);
    if (watched_.size() != 2) return;
    pair_ = {watched_[0], watched_[1]};
    auto traced = [&](int id) {
      return std::find(s.traced.begin(), s.traced.end(), id) != s.traced.end();
    };
    pair_traced_ = traced(pair_->first) && traced(pair_->second);
    if (!pair_traced_ || !s.resume_at) return;
    // The traces before the checkpoint, as TracesRecorder wrote them (it has
    // cut traces.csv back already: it is made first).
    const TraceTable table = read_traces_csv(s.dir / TracesRecorder::kFile);
    auto column = [&](int id) {
      const auto name = "vx_" + std::to_string(id);
      return table.values[static_cast<std::size_t>(
          std::find(table.columns.begin(), table.columns.end(), name) - table.columns.begin())];
    };
    pair_t_ = table.t;
    pair_va_ = column(pair_->first);
    pair_vb_ = column(pair_->second);
  }
  void record(double t, std::span<const double> y) override {
    if (!pair_traced_) return;
    pair_t_.push_back(t);
    pair_va_.push_back(system_.contact_velocity(static_cast<std::size_t>(pair_->first), y)[0]);
    pair_vb_.push_back(system_.contact_velocity(static_cast<std::size_t>(pair_->second), y)[0]);
  }
  void event(const Event& e) override {
    events_.push_back(e);
    char line[160];
    std::snprintf(line, sizeof line, "%.15g,%d,%s,%.10g,%.10g", e.t, e.contact,
                  std::string(to_string(e.kind)).c_str(), e.speed, e.force);
    csv_.line(line);
  }
  void flush() override { csv_.flush(); }
  void finish(double t_end, std::span<const double>, Summary& summary) override {
    const double t_avg = average_from_;
    EventSummary events{static_cast<long>(events_.size()), t_avg, t_end, {}};
    for (int id : watched_)
      events.per_contact.push_back(contact_statistics(
          events_, id, slipping_at_start_[static_cast<std::size_t>(id)], t_avg, t_end));
    summary.events = std::move(events);
    if (!pair_) return;
    const auto& contacts = system_.contacts();
    const double window = travel_time(system_, contacts[static_cast<std::size_t>(pair_->first)],
                                      contacts[static_cast<std::size_t>(pair_->second)]);
    // Only the averaging window is correlated: the start from rest is a transient.
    summary.synchronization = synchronization(events_, pair_->first, pair_->second, window, t_avg,
                                              t_end, pair_t_, pair_va_, pair_vb_);
  }

 private:
  const System& system_;
  double average_from_;
  std::vector<int> watched_;
  CsvWriter csv_;
  std::vector<Event> events_;
  std::vector<bool> slipping_at_start_;
  std::optional<std::pair<int, int>> pair_;
  bool pair_traced_ = false;
  std::vector<double> pair_t_, pair_va_, pair_vb_;
};

// steps.csv: every accepted step's size and error estimate.
class StepsRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "steps.csv";
  explicit StepsRecorder(const RecorderSetup& s)
      : csv_(open_table(s, kFile, {"t", "h", "error"})) {}
  bool wants_steps() const override { return true; }
  void step(const StepRecord& r) override {
    const double row[2] = {r.h, r.error};
    csv_.row(r.t, row);
  }
  void flush() override { csv_.flush(); }

 private:
  CsvWriter csv_;
};

// signals.csv: the block's centre-of-mass velocity, the contacts' impulse and
// the acoustic signal, its second difference over the output times (README).
class SignalsRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "signals.csv";
  explicit SignalsRecorder(const RecorderSetup& s)
      : system_(s.system),
        csv_(open_table(s, kFile, {"t", "block_velocity", "contact_impulse", "acoustic"})) {
    csv_.full_precision();  // the impulse is differenced twice
    if (!s.resume_at) return;
    // The last two rows' (t, impulse), to difference the next ones.
    const TraceTable written = read_traces_csv(s.dir / kFile);
    const auto& impulses = written.values[1];  // block_velocity, contact_impulse, acoustic
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
    const double values[3] = {system_.block_velocity(y), impulse, acoustic};
    csv_.row(t, values);
  }
  void flush() override { csv_.flush(); }

 private:
  const System& system_;
  CsvWriter csv_;
  std::vector<std::array<double, 2>> last_;
};

// final_state.csv: every node's displacement and velocity at t_end, 17
// digits, for comparing runs state by state (bench/work_precision.py).
class FinalStateRecorder final : public Recorder {
 public:
  static constexpr const char* kFile = "final_state.csv";
  explicit FinalStateRecorder(const RecorderSetup& s) : system_(s.system), dir_(s.dir) {}
  void finish(double t_end, std::span<const double> y, Summary&) override {
    CsvWriter state(dir_ / kFile,
                    {"t", "ix", "iy", "iz", "u_x", "u_y", "u_z", "w_x", "w_y", "w_z"});
    state.full_precision();
    std::array<double, 9> row{};
    for (int iz = 0; iz < system_.nz(); ++iz)
      for (int iy = 0; iy < system_.ny(); ++iy)
        for (int ix = 0; ix < system_.nx(); ++ix) {
          const std::int64_t n = system_.node(ix, iy, iz);
          row = {double(ix), double(iy), double(iz)};
          for (int k = 0; k < 3; ++k) {
            row[3 + k] = y[static_cast<std::size_t>(system_.u_index(n, k))];
            row[6 + k] = y[static_cast<std::size_t>(system_.w_index(n, k))];
          }
          state.row(t_end, row);
        }
  }

 private:
  const System& system_;
  fs::path dir_;
};

// The registry: each output's file, and whether the case asks for it. Made
// in this order (events reads back what traces cut on a restart).
struct RecorderKind {
  const char* file;
  bool (*asked)(const RecorderSetup&);
  std::unique_ptr<Recorder> (*make)(const RecorderSetup&);
};

template <class R>
std::unique_ptr<Recorder> make(const RecorderSetup& s) {
  return std::make_unique<R>(s);
}

constexpr RecorderKind kRecorders[] = {
    {ContactsRecorder::kFile, [](const RecorderSetup&) { return true; }, make<ContactsRecorder>},
    {FrictionRecorder::kFile, [](const RecorderSetup&) { return true; }, make<FrictionRecorder>},
    {TracesRecorder::kFile, [](const RecorderSetup& s) { return !s.traced.empty(); },
     make<TracesRecorder>},
    {EventsRecorder::kFile, [](const RecorderSetup& s) { return !s.watched.empty(); },
     make<EventsRecorder>},
    {StepsRecorder::kFile, [](const RecorderSetup& s) { return s.c.output.steps; },
     make<StepsRecorder>},
    {SignalsRecorder::kFile, [](const RecorderSetup& s) { return s.c.output.signals; },
     make<SignalsRecorder>},
    {FinalStateRecorder::kFile, [](const RecorderSetup& s) { return s.c.output.final_state; },
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

std::vector<std::string> recorder_files() {
  std::vector<std::string> files;
  for (const auto& kind : kRecorders) files.emplace_back(kind.file);
  return files;
}

}  // namespace stickslip
