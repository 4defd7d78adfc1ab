// A run's tables in one HDF5 file: a group per table, a chunked dataset per
// column that grows as rows come (a 2-D one [row × member] for columns that
// share a `dataset`), rows buffered and written in blocks, the file flushed
// whenever the recorders flush. A run stopped by a signal closes the file; a
// killed one leaves what was flushed in practice (HDF5 without SWMR does not
// promise it: it may write metadata between flushes). The table's first
// dataset (time, or contacts' id) is an HDF5 dimension scale attached to
// every other dataset's rows, the member ids (traces/contact) one attached
// to the 2-D datasets' columns, and every quantity has its unit as the
// attribute "units": h5py, h5netcdf and xarray see labelled dimensions
// without this code's help.
#include "hdf5_tables.hpp"

#include <hdf5.h>
#include <hdf5_hl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

namespace fs = std::filesystem;

// An HDF5 identifier, closed with its own close function when it goes.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), close_(o.close_) {}
  Handle& operator=(Handle&& o) noexcept {
    std::swap(id_, o.id_);
    std::swap(close_, o.close_);
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0 && close_) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

// HDF5 prints its own error stack unless told not to; the errors thrown here
// say what failed, with HDF5's innermost reason (why_hdf5). Debian's HDF5 is
// built thread-safe, which keeps this setting per thread: once per thread
// (runs in threads of one process, from the Python module).
void silence_hdf5() {
  thread_local const bool once = [] { return H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0; }();
  (void)once;
}

// The innermost message of HDF5's error stack, e.g. "unable to lock file,
// errno = 11, ...", as " (HDF5: ...)"; "" if the stack is empty.
std::string why_hdf5() {
  std::string reason;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
        auto& r = *static_cast<std::string*>(data);
        if (r.empty() && e->desc) r = e->desc;
        return 0;
      },
      &reason);
  return reason.empty() ? std::string() : " (HDF5: " + reason + ")";
}

// Rows kept in memory before they are written as one block (HDF5 writes of a
// row each would cost more than the row).
constexpr std::size_t kBlockRows = 4096;
// Chunks of up to 1024 rows and at most 1 MiB (HDF5's default chunk cache),
// however many contacts a 2-D dataset has.
hsize_t chunk_rows(hsize_t width) {
  return std::clamp<hsize_t>((hsize_t{1} << 17) / width, 1, 1024);
}

// One dataset of a table: the spec's columns it holds, in member order.
struct DatasetLayout {
  std::string name;
  const Column* first = nullptr;  // type and unit
  std::vector<std::size_t> columns;
};

constexpr std::size_t kNoColumn = static_cast<std::size_t>(-1);

std::vector<DatasetLayout> layout(const TableSpec& spec) {
  std::vector<DatasetLayout> sets;
  for (std::size_t i = 0; i < spec.columns.size(); ++i) {
    const Column& c = spec.columns[i];
    const std::string& name = c.dataset.empty() ? c.name : c.dataset;
    auto it = std::find_if(sets.begin(), sets.end(), [&](const auto& d) { return d.name == name; });
    if (it == sets.end()) it = sets.insert(sets.end(), DatasetLayout{name, &c, {}});
    const auto member = static_cast<std::size_t>(std::max(c.member, 0));
    if (it->columns.size() <= member) it->columns.resize(member + 1, kNoColumn);
    it->columns[member] = i;
  }
  for (const DatasetLayout& d : sets)
    if (std::count(d.columns.begin(), d.columns.end(), kNoColumn))
      throw std::logic_error("table " + spec.name + ": dataset " + d.name + " misses a member");
  return sets;
}

// The in-memory type of a column's values (the file's is the same, little-endian).
Handle memory_type(const Column& c) {
  switch (c.type) {
    case ColumnType::real:
      return {H5Tcopy(H5T_NATIVE_DOUBLE), H5Tclose};
    case ColumnType::integer:
      return {H5Tcopy(H5T_NATIVE_INT64), H5Tclose};
    case ColumnType::label: {
      // An HDF5 enumeration: h5py and h5dump show the labels.
      Handle type(H5Tenum_create(H5T_NATIVE_INT8), H5Tclose);
      for (std::size_t k = 0; k < c.labels.size(); ++k) {
        const auto value = static_cast<std::int8_t>(k);
        if (H5Tenum_insert(type.get(), c.labels[k].c_str(), &value) < 0)
          throw std::logic_error("label " + c.labels[k] + " of column " + c.name + why_hdf5());
      }
      return type;
    }
  }
  return {};
}

void write_text_attribute(hid_t object, const std::string& name, const std::string& text,
                          const fs::path& file) {
  if (H5Aexists(object, name.c_str()) > 0) H5Adelete(object, name.c_str());
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(
      H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Aclose);
  const char* data = text.c_str();
  if (!attribute.valid() || H5Awrite(attribute.get(), type.get(), &data) < 0)
    throw OutputError(file.string() + ": cannot write the attribute " + name + why_hdf5());
}

class Hdf5Table final : public Table {
 public:
  // A new group, replacing one of that name.
  Hdf5Table(std::shared_ptr<Handle> file, const fs::path& path, const TableSpec& spec)
      : file_(std::move(file)), path_(path), spec_(spec), sets_(layout(spec_)) {
    const hid_t f = file_->get();
    if (H5Lexists(f, spec_.name.c_str(), H5P_DEFAULT) > 0)
      H5Ldelete(f, spec_.name.c_str(), H5P_DEFAULT);
    // Datasets are listed in the order they were made (the CSV's column order).
    Handle properties(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
    H5Pset_link_creation_order(properties.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
    group_ = Handle(H5Gcreate2(f, spec_.name.c_str(), H5P_DEFAULT, properties.get(), H5P_DEFAULT),
                    H5Gclose);
    if (!group_.valid()) fail("cannot create the group");
    for (const DatasetLayout& d : sets_) {
      const hsize_t width = d.columns.size();
      const bool wide = d.first->member >= 0;
      const hsize_t dims[2] = {0, width}, max[2] = {H5S_UNLIMITED, width};
      const hsize_t chunk[2] = {chunk_rows(width), width};
      Handle space(H5Screate_simple(wide ? 2 : 1, dims, max), H5Sclose);
      Handle create(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
      H5Pset_chunk(create.get(), wide ? 2 : 1, chunk);
      Handle type = memory_type(*d.first);
      Handle set(H5Dcreate2(group_.get(), d.name.c_str(), type.get(), space.get(), H5P_DEFAULT,
                            create.get(), H5P_DEFAULT),
                 H5Dclose);
      if (!set.valid()) fail("cannot create the dataset " + d.name);
      if (!d.first->unit.empty()) write_text_attribute(set.get(), "units", d.first->unit, path_);
      if (wide) write_text_attribute(set.get(), "members", spec_.member_name, path_);
      datasets_.push_back(std::move(set));
      types_.push_back(std::move(type));
    }
    if (!spec_.members.empty()) write_members();
    attach_scales();
  }

  // The existing group, its rows after time t dropped.
  Hdf5Table(std::shared_ptr<Handle> file, const fs::path& path, const TableSpec& spec, double t)
      : file_(std::move(file)), path_(path), spec_(spec), sets_(layout(spec_)) {
    group_ = Handle(H5Gopen2(file_->get(), spec_.name.c_str(), H5P_DEFAULT), H5Gclose);
    if (!group_.valid()) fail("missing; the run cannot continue without it");
    for (const DatasetLayout& d : sets_) {
      Handle set(H5Dopen2(group_.get(), d.name.c_str(), H5P_DEFAULT), H5Dclose);
      if (!set.valid()) fail("the dataset " + d.name + " is missing");
      datasets_.push_back(std::move(set));
      types_.push_back(memory_type(*d.first));
    }
    // Rows are in time order (the first dataset is time): keep those up to t.
    std::vector<double> times(rows_in(datasets_.front().get()));
    if (!times.empty() && H5Dread(datasets_.front().get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL,
                                  H5P_DEFAULT, times.data()) < 0)
      fail("cannot read " + sets_.front().name);
    // The same rule as the CSV tables' (whose times are printed to 12 digits).
    written_ = static_cast<hsize_t>(std::upper_bound(times.begin(), times.end(), t * (1 + 1e-10)) -
                                    times.begin());
    for (std::size_t k = 0; k < sets_.size(); ++k) {
      const hsize_t extent[2] = {written_, sets_[k].columns.size()};
      if (H5Dset_extent(datasets_[k].get(), extent) < 0) fail("cannot cut back " + sets_[k].name);
    }
    // A file written before tables had dimension scales gets them now.
    if (H5DSis_scale(datasets_.front().get()) <= 0) attach_scales();
  }

  ~Hdf5Table() override {
    try {
      write_pending();
    } catch (...) {  // a destructor must not throw; flush() reports errors
    }
  }

  void append(std::span<const double> row) override {
    check_row(row, spec_.columns.size());
    pending_.insert(pending_.end(), row.begin(), row.end());
    if (pending_.size() >= kBlockRows * spec_.columns.size()) write_pending();
  }

  void flush() override {
    write_pending();
    if (H5Fflush(file_->get(), H5F_SCOPE_GLOBAL) < 0) fail("cannot flush");
  }

 private:
  [[noreturn]] void fail(const std::string& why) const {
    throw OutputError(path_.string() + ": /" + spec_.name + ": " + why + why_hdf5());
  }

  static hsize_t rows_in(hid_t set) {
    Handle space(H5Dget_space(set), H5Sclose);
    hsize_t dims[2] = {0, 0};
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    return dims[0];
  }

  // The first dataset becomes the scale of every other's rows; the members'
  // dataset the scale of the 2-D datasets' columns.
  void attach_scales() {
    const hid_t rows = datasets_.front().get();
    if (H5DSset_scale(rows, sets_.front().name.c_str()) < 0)
      fail("cannot make " + sets_.front().name + " a dimension scale");
    Handle members;
    if (!spec_.members.empty()) {
      members = Handle(H5Dopen2(group_.get(), spec_.member_name.c_str(), H5P_DEFAULT), H5Dclose);
      if (!members.valid() || H5DSset_scale(members.get(), spec_.member_name.c_str()) < 0)
        fail("cannot make " + spec_.member_name + " a dimension scale");
    }
    for (std::size_t k = 1; k < sets_.size(); ++k) {
      const hid_t set = datasets_[k].get();
      if (H5DSattach_scale(set, rows, 0) < 0)
        fail("cannot attach " + sets_.front().name + " to " + sets_[k].name);
      if (sets_[k].first->member >= 0 && members.valid() &&
          H5DSattach_scale(set, members.get(), 1) < 0)
        fail("cannot attach " + spec_.member_name + " to " + sets_[k].name);
    }
  }

  void write_members() {
    const hsize_t n = spec_.members.size();
    Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
    Handle set(H5Dcreate2(group_.get(), spec_.member_name.c_str(), H5T_STD_I64LE, space.get(),
                          H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose);
    std::vector<std::int64_t> ids(spec_.members.begin(), spec_.members.end());
    if (!set.valid() ||
        H5Dwrite(set.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, ids.data()) < 0)
      fail("cannot write " + spec_.member_name);
  }

  // Values of `d`'s columns for the pending rows, row-major, as type T.
  template <class T>
  std::vector<T> gather(const DatasetLayout& d, std::size_t rows) const {
    const std::size_t width = spec_.columns.size();
    std::vector<T> out;
    out.reserve(rows * d.columns.size());
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c : d.columns) {
        const double v = pending_[r * width + c];
        if constexpr (std::is_floating_point_v<T>)
          out.push_back(v);
        else
          out.push_back(static_cast<T>(std::llround(v)));
      }
    return out;
  }

  void write_pending() {
    const std::size_t rows = pending_.size() / spec_.columns.size();
    if (rows == 0) return;
    for (std::size_t k = 0; k < sets_.size(); ++k) {
      const DatasetLayout& d = sets_[k];
      const hid_t set = datasets_[k].get();
      const hsize_t width = d.columns.size();
      const hsize_t extent[2] = {written_ + rows, width};
      if (H5Dset_extent(set, extent) < 0) fail("cannot grow " + d.name);
      Handle file_space(H5Dget_space(set), H5Sclose);
      const int rank = H5Sget_simple_extent_ndims(file_space.get());
      const hsize_t start[2] = {written_, 0}, count[2] = {rows, width};
      H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
      Handle memory_space(H5Screate_simple(rank, count, nullptr), H5Sclose);
      herr_t status = -1;
      const hid_t type = types_[k].get();
      switch (d.first->type) {
        case ColumnType::real:
          status = H5Dwrite(set, type, memory_space.get(), file_space.get(), H5P_DEFAULT,
                            gather<double>(d, rows).data());
          break;
        case ColumnType::integer:
          status = H5Dwrite(set, type, memory_space.get(), file_space.get(), H5P_DEFAULT,
                            gather<std::int64_t>(d, rows).data());
          break;
        case ColumnType::label:
          status = H5Dwrite(set, type, memory_space.get(), file_space.get(), H5P_DEFAULT,
                            gather<std::int8_t>(d, rows).data());
          break;
      }
      if (status < 0) fail("cannot write " + d.name);
    }
    written_ += rows;
    pending_.clear();
  }

  std::shared_ptr<Handle> file_;
  fs::path path_;
  TableSpec spec_;
  std::vector<DatasetLayout> sets_;
  Handle group_;
  std::vector<Handle> datasets_, types_;
  std::vector<double> pending_;  // rows not yet written, row-major
  hsize_t written_ = 0;
};

class Hdf5Store final : public TableStore {
 public:
  Hdf5Store(const fs::path& path, bool resume) : path_(path) {
    silence_hdf5();
    const hid_t id = resume ? H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)
                            : H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (id < 0)
      throw OutputError(path.string() + ": cannot " + (resume ? "open for appending" : "create") +
                        why_hdf5());
    file_ = std::make_shared<Handle>(id, H5Fclose);
  }
  std::unique_ptr<Table> create(const TableSpec& spec) override {
    return std::make_unique<Hdf5Table>(file_, path_, spec);
  }
  std::unique_ptr<Table> resume(const TableSpec& spec, double t) override {
    return std::make_unique<Hdf5Table>(file_, path_, spec, t);
  }
  void set_attribute(const std::string& name, const std::string& text) override {
    write_text_attribute(file_->get(), name, text, path_);
    if (H5Fflush(file_->get(), H5F_SCOPE_GLOBAL) < 0)
      throw OutputError(path_.string() + ": cannot flush" + why_hdf5());
  }

 private:
  fs::path path_;
  std::shared_ptr<Handle> file_;
};

Handle open_for_reading(const fs::path& file) {
  silence_hdf5();
  // Without taking the file lock: a run in progress holds it, and what it
  // has flushed is worth reading (plots, compare) while it goes on.
  Handle access(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_file_locking(access.get(), false, true);
  Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, access.get()), H5Fclose);
  // This process's own run has it open already (a recorder reading its table
  // back), with the lock: HDF5 shares that open file only with the same flags.
  if (!f.valid()) f = Handle(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw OutputError(file.string() + ": cannot open" + why_hdf5());
  return f;
}

std::string text_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return {};
  Handle attribute(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);  // as written: HDF5 converts no character set
  char* data = nullptr;
  if (H5Aread(attribute.get(), type.get(), &data) < 0 || !data) return {};
  std::string text(data);
  H5free_memory(data);
  return text;
}

}  // namespace

std::unique_ptr<TableStore> make_hdf5_store(const fs::path& file, bool resume) {
  return std::make_unique<Hdf5Store>(file, resume);
}

std::string read_hdf5_attribute(const fs::path& file, const std::string& name) {
  const Handle f = open_for_reading(file);
  return text_attribute(f.get(), name.c_str());
}

bool hdf5_has_table(const fs::path& file, const std::string& name) {
  const Handle f = open_for_reading(file);
  return H5Lexists(f.get(), name.c_str(), H5P_DEFAULT) > 0;
}

std::vector<std::pair<std::string, std::vector<double>>> read_hdf5_table(const fs::path& file,
                                                                         const std::string& name) {
  const Handle f = open_for_reading(file);
  const std::string where = file.string() + ": /" + name;
  Handle group(H5Gopen2(f.get(), name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw OutputError(where + ": no such table");
  H5G_info_t info;
  if (H5Gget_info(group.get(), &info) < 0)
    throw OutputError(where + ": cannot list the datasets" + why_hdf5());
  // The datasets in the order they were made; a 2-D one names the dataset
  // that lists its members, which is not a column itself.
  struct Set {
    std::string name, members;
    std::vector<double> values;
    hsize_t rows = 0, width = 1;
  };
  std::vector<Set> sets;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char link[256];
    if (H5Lget_name_by_idx(group.get(), ".", H5_INDEX_CRT_ORDER, H5_ITER_INC, i, link, sizeof link,
                           H5P_DEFAULT) < 0)
      throw OutputError(where + ": cannot list the datasets");
    Handle set(H5Dopen2(group.get(), link, H5P_DEFAULT), H5Dclose);
    if (!set.valid()) throw OutputError(where + "/" + link + ": not a dataset");
    Set s{link, text_attribute(set.get(), "members"), {}};
    Handle space(H5Dget_space(set.get()), H5Sclose);
    hsize_t dims[2] = {0, 1};
    const int rank = H5Sget_simple_extent_ndims(space.get());
    if (rank < 1 || rank > 2) throw OutputError(where + "/" + link + ": not 1-D or 2-D");
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    s.rows = dims[0];
    s.width = rank == 2 ? dims[1] : 1;
    s.values.resize(s.rows * s.width);
    Handle stored(H5Dget_type(set.get()), H5Tclose);
    herr_t status = 0;
    if (s.values.empty()) {
    } else if (H5Tget_class(stored.get()) == H5T_ENUM) {
      // Labels read as their numbers: HDF5 converts an enumeration to no
      // number type, so it is read as its own (one-byte) type and widened.
      Handle native(H5Tget_native_type(stored.get(), H5T_DIR_ASCEND), H5Tclose);
      if (H5Tget_size(native.get()) != 1)
        throw OutputError(where + "/" + link + ": an enumeration wider than one byte");
      std::vector<std::int8_t> codes(s.values.size());
      status = H5Dread(set.get(), native.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, codes.data());
      std::copy(codes.begin(), codes.end(), s.values.begin());
    } else {
      status =
          H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, s.values.data());
    }
    if (status < 0) throw OutputError(where + "/" + link + ": cannot read");
    sets.push_back(std::move(s));
  }
  std::vector<std::pair<std::string, std::vector<double>>> columns;
  const hsize_t rows = sets.empty() ? 0 : sets.front().rows;
  for (const Set& s : sets) {
    if (std::any_of(sets.begin(), sets.end(), [&](const Set& o) { return o.members == s.name; }))
      continue;  // the members of a 2-D dataset
    if (s.rows != rows)
      throw OutputError(where + "/" + s.name + ": " + std::to_string(s.rows) + " rows, not " +
                        std::to_string(rows) + " as " + sets.front().name);
    if (s.members.empty()) {
      if (s.width != 1)
        throw OutputError(where + "/" + s.name + ": 2-D without a \"members\" attribute");
      columns.emplace_back(s.name, s.values);
      continue;
    }
    const auto ids =
        std::find_if(sets.begin(), sets.end(), [&](const Set& o) { return o.name == s.members; });
    if (ids == sets.end() || ids->values.size() != s.width)
      throw OutputError(where + "/" + s.name + ": its members (" + s.members +
                        ") are missing or do not match its width");
    for (hsize_t m = 0; m < s.width; ++m) {
      std::vector<double> column(rows);
      for (hsize_t r = 0; r < rows; ++r) column[r] = s.values[r * s.width + m];
      columns.emplace_back(member_column(s.name, static_cast<int>(std::llround(ids->values[m]))),
                           std::move(column));
    }
  }
  return columns;
}

}  // namespace stickslip
