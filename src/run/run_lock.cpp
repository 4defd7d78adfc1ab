#include "stickslip/run/run_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <sstream>
#include <system_error>

namespace stickslip {
namespace {

namespace fs = std::filesystem;

// What the lock file says of the run holding it: "pid <n>", "host <name>",
// "started <UTC time>", a line each.
std::string holder_text() {
  char host[256] = "unknown";
  if (gethostname(host, sizeof host) != 0) std::strcpy(host, "unknown");
  host[sizeof host - 1] = '\0';
  char started[32] = "unknown";
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  if (gmtime_r(&now, &utc)) std::strftime(started, sizeof started, "%Y-%m-%d %H:%M:%S UTC", &utc);
  return "pid " + std::to_string(getpid()) + "\nhost " + host + "\nstarted " + started + "\n";
}

// The live run's refusal, from what its lock file says (read through our
// own descriptor of it: the holder may be writing it just now).
[[noreturn]] void refuse_live(const fs::path& dir, int fd) {
  std::string text(512, '\0');
  const ssize_t n = pread(fd, text.data(), text.size(), 0);
  text.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  long pid = 0;
  std::string host, started, line;
  std::istringstream lines(text);
  while (std::getline(lines, line)) {
    if (line.rfind("pid ", 0) == 0) pid = std::strtol(line.c_str() + 4, nullptr, 10);
    if (line.rfind("host ", 0) == 0) host = line.substr(5);
    if (line.rfind("started ", 0) == 0) started = line.substr(8);
  }
  close(fd);
  // Just locked, the holder may not have said who it is yet.
  const std::string who = pid > 0
                              ? "pid " + std::to_string(pid) + (host.empty() ? "" : " on " + host) +
                                    (started.empty() ? "" : ", started " + started)
                              : "its pid not written yet";
  const std::string stop = pid > 0 ? "stop it (kill " + std::to_string(pid) +
                                         ": it checkpoints, and --restart continues it later)"
                                   : "stop it";
  throw LiveRunError(dir.string() + ": a live run is writing there (" + who +
                         "); nothing there was touched: wait for it to end, " + stop +
                         ", or choose another output directory",
                     pid);
}

}  // namespace

RunLock::RunLock(const fs::path& dir, bool create) : file_(dir / kRunLockFile) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw OutputError(dir.string() + ": output path exists and is not a directory");
  if (!fs::exists(dir, ec)) {
    if (!create) return;
    fs::create_directories(dir, ec);
    if (ec) throw OutputError(dir.string() + ": cannot create output directory: " + ec.message());
  }
  for (;;) {
    // O_CLOEXEC: a program the run starts does not inherit the lock.
    const int fd = open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      if (errno == EACCES || errno == EROFS || errno == EPERM)
        throw OutputError(dir.string() + ": output directory is not writable");
      throw OutputError(file_.string() + ": cannot open: " + std::strerror(errno));
    }
    // flock, not fcntl's record locks: those belong to the process, so two
    // runs in one process (the Python module's threads, a test) would not
    // exclude each other, and closing any descriptor of the file would drop them.
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      if (errno == EWOULDBLOCK) refuse_live(dir, fd);
      const std::string reason = std::strerror(errno);
      close(fd);
      throw OutputError(file_.string() + ": cannot lock: " + reason);
    }
    // A run that ends removes its lock file before it lets go of the lock;
    // if that happened between our open and our flock, we hold a file no
    // longer in the directory (and a third run may hold the new one): again.
    struct stat held {
    }, named{};
    if (fstat(fd, &held) == 0 && stat(file_.c_str(), &named) == 0 && held.st_dev == named.st_dev &&
        held.st_ino == named.st_ino) {
      fd_ = fd;
      break;
    }
    close(fd);
  }
  // Who holds it, for a refused run's message; the lock, not the text, is
  // what excludes, so a failed write is no reason to stop.
  const std::string text = holder_text();
  const bool said = ftruncate(fd_, 0) == 0 &&
                    pwrite(fd_, text.data(), text.size(), 0) == static_cast<ssize_t>(text.size());
  static_cast<void>(said);
}

RunLock::~RunLock() {
  if (fd_ < 0) return;
  // Removed while still held: a run waiting on this file finds it gone and
  // takes a new one (above).
  unlink(file_.c_str());
  close(fd_);
}

}  // namespace stickslip
