#pragma once
// One run per output directory. A run holds its directory's lock, run.lock,
// from before it reads or changes anything there (restart admission,
// --overwrite's removals: run/resume.hpp) until it ends, normally, by an
// exception or stopped by a signal. A second run into the directory, started
// afresh, with --overwrite or with --restart, is refused while the first
// lives: two runs would interleave their rows and summaries in the same files.
//
// The lock is the OS's (flock on the open file), not the file's existence: a
// killed run's lock goes with its process, and the run.lock it leaves behind
// blocks nothing. The file says who holds it (pid, host, start time) for the
// refusal's message. On NFS, Linux emulates flock with a POSIX lock on the
// server, which still excludes a run on another host.

#include <filesystem>
#include <string>

#include "stickslip/output/writers.hpp"

namespace stickslip {

inline constexpr const char* kRunLockFile = "run.lock";

// A run into a directory that a live run holds; nothing there was touched.
class LiveRunError : public OutputError {
 public:
  LiveRunError(const std::string& what, long pid) : OutputError(what), pid(pid) {}
  long pid;  // the live run's, as its lock file says (0 if it has not said yet)
};

class RunLock {
 public:
  // Takes the lock of `dir` for this run, creating `dir` if it is missing
  // and `create` (a fresh start); a missing `dir` without `create` (a restart
  // of nothing, which restart admission refuses) is left missing and
  // unlocked. LiveRunError if a live run holds it; OutputError if it cannot
  // be taken (not a directory, not writable, no locks on this file system).
  RunLock(const std::filesystem::path& dir, bool create);
  // Removes run.lock and releases the lock.
  ~RunLock();
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

 private:
  std::filesystem::path file_;
  int fd_ = -1;
};

}  // namespace stickslip
