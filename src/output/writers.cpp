#include "stickslip/output/writers.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <system_error>

namespace stickslip {

void prepare_output_dir(const std::filesystem::path& dir, bool overwrite,
                        std::span<const std::string> result_files) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw OutputError(dir.string() + ": output path exists and is not a directory");
  for (const std::string& name : result_files) {
    const fs::path file = dir / name;
    if (!fs::exists(file, ec)) continue;
    if (!overwrite)
      throw OutputError(dir.string() + ": holds results of an earlier run (" + name +
                        "); pass --overwrite to replace them, or choose another "
                        "output directory");
    if (!fs::is_regular_file(file, ec))
      throw OutputError(file.string() + ": is not a regular file; refusing to replace it");
    fs::remove(file, ec);
    if (ec) throw OutputError(file.string() + ": cannot remove: " + ec.message());
  }
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(dir.string() + ": cannot create output directory: " + ec.message());
  const fs::path probe = dir / ".stickslip-write-test";
  {
    std::ofstream test(probe);
    if (!test) throw OutputError(dir.string() + ": output directory is not writable");
  }
  fs::remove(probe, ec);
}

void keep_rows_up_to(const std::filesystem::path& file, double t) {
  std::ifstream in(file);
  if (!in) return;
  std::string header, line, kept;
  std::getline(in, header);
  kept = header + '\n';
  while (std::getline(in, line)) {
    // A last line without its newline was cut off mid-write (a killed run):
    // its numbers may be truncated, so it goes whatever its time.
    if (in.eof()) break;
    // Rows are in time order; times are printed to 12 digits, so the row at t
    // itself may read back a little above it.
    if (std::strtod(line.c_str(), nullptr) > t * (1 + 1e-10)) break;
    kept += line + '\n';
  }
  in.close();
  write_atomically(file, [&](std::ostream& out) { out << kept; });
}

void write_atomically(const std::filesystem::path& file,
                      const std::function<void(std::ostream&)>& write) {
  const auto tmp = std::filesystem::path(file.string() + "." + std::to_string(getpid()) + ".tmp");
  std::error_code ec;
  // A write that fails says why (the OS's reason: "No space left on device")
  // and leaves no temporary file behind; the file it would replace is kept.
  auto fail = [&](const char* what) {
    const std::string reason = errno ? std::strerror(errno) : "unknown reason";
    std::filesystem::remove(tmp, ec);
    throw OutputError(tmp.string() + ": " + what + ": " + reason);
  };
  {
    errno = 0;
    std::ofstream out(tmp, std::ios::binary);
    if (!out) fail("cannot open for writing");
    try {
      write(out);
    } catch (...) {
      out.close();
      std::filesystem::remove(tmp, ec);
      throw;
    }
    if (!out.flush()) {
      const int saved = errno;
      out.close();
      errno = saved;
      fail("write failed");
    }
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) throw OutputError(file.string() + ": cannot replace: " + ec.message());
}

void write_json_atomically(const std::filesystem::path& file, const nlohmann::json& value) {
  write_atomically(file, [&](std::ostream& out) { out << value.dump(2) << '\n'; });
}

}  // namespace stickslip
