#include "stickslip/output/table_store.hpp"

#include <algorithm>
#include <charconv>
#include <stdexcept>
#include <string>
#include <system_error>

namespace stickslip {

std::string csv_file_name(std::string_view table) {
  return std::string(table) + ".csv";
}

std::string member_column(std::string_view dataset, int member) {
  return std::string(dataset) + "_" + std::to_string(member);
}

std::optional<int> column_member(std::string_view name, std::string_view dataset) {
  if (name.size() <= dataset.size() + 1 || name.substr(0, dataset.size()) != dataset ||
      name[dataset.size()] != '_')
    return std::nullopt;
  const std::string_view digits = name.substr(dataset.size() + 1);
  int member = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), member);
  if (error != std::errc() || end != digits.data() + digits.size() || member < 0)
    return std::nullopt;
  return member;
}

namespace {

// The rows of a table kept by TrackedTableStore: a rejected or overshooting
// step writes one row past the time a checkpoint is taken at, never many.
constexpr std::size_t kRecentRows = 16;

// A table whose rows' times are noted in `times` on their way to `table`.
class TrackedTable final : public Table {
 public:
  TrackedTable(std::unique_ptr<Table> table, std::deque<double>* times)
      : table_(std::move(table)), times_(times) {}
  void append(std::span<const double> row) override {
    table_->append(row);
    if (!times_ || row.empty()) return;
    times_->push_back(row[0]);
    if (times_->size() > kRecentRows) times_->pop_front();
  }
  void flush() override { table_->flush(); }

 private:
  std::unique_ptr<Table> table_;
  std::deque<double>* times_;  // null: a table whose first column is no time (contacts)
};

bool timed(const TableSpec& spec) {
  return !spec.columns.empty() && spec.columns.front().unit == "s";
}

}  // namespace

TrackedTableStore::TrackedTableStore(std::unique_ptr<TableStore> store,
                                     const std::map<std::string, double>& reached)
    : store_(std::move(store)) {
  for (const auto& [name, t] : reached) recent_[name].push_back(t);
}

std::unique_ptr<Table> TrackedTableStore::create(const TableSpec& spec) {
  auto table = store_->create(spec);
  if (!timed(spec)) return table;
  auto& times = recent_[spec.name];
  times.clear();  // a table created anew has no rows
  return std::make_unique<TrackedTable>(std::move(table), &times);
}

std::unique_ptr<Table> TrackedTableStore::resume(const TableSpec& spec, double t) {
  auto table = store_->resume(spec, t);
  if (!timed(spec)) return table;
  auto& times = recent_[spec.name];
  std::erase_if(times, [t](double ti) { return ti > t; });  // cut back with the table
  return std::make_unique<TrackedTable>(std::move(table), &times);
}

void TrackedTableStore::set_attribute(const std::string& name, const std::string& text) {
  store_->set_attribute(name, text);
}

std::map<std::string, double> TrackedTableStore::last_rows(double t) const {
  std::map<std::string, double> last;
  for (const auto& [name, times] : recent_) {
    const auto at = std::find_if(times.rbegin(), times.rend(), [t](double ti) { return ti <= t; });
    if (at != times.rend()) last[name] = *at;
  }
  return last;
}

void check_row(std::span<const double> row, std::size_t columns) {
  if (row.size() != columns)
    throw std::logic_error("a table row of " + std::to_string(row.size()) + " values for " +
                           std::to_string(columns) + " columns");
}

}  // namespace stickslip
