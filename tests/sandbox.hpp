#pragma once
// Running the real binary in a throw-away directory, for the command-line
// tests: `work` is the program's working directory and holds case files and
// outputs; captured stdout and stderr live beside it, so a snapshot of `work`
// sees everything the program may have written.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace stickslip::test {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

inline void spit(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}

inline std::string quote(const std::string& s) {  // for /bin/sh
  std::string q = "'";
  for (char ch : s) q += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return q + "'";
}

inline std::size_t lines(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

struct Result {
  int code;
  std::string out, err;
};

struct Sandbox {
  fs::path root, work;
  explicit Sandbox(const std::string& prefix = "stickslip_cli_") {
    static std::atomic<int> counter{0};
    root = fs::temp_directory_path() /
           (prefix + std::to_string(getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(root);
    work = root / "work";
    fs::create_directories(work);
  }
  ~Sandbox() {
    std::error_code ec;
    fs::permissions(work / "readonly", fs::perms::owner_all, ec);  // if a test made one
    fs::remove_all(root, ec);
  }
  Sandbox(const Sandbox&) = delete;
  Sandbox& operator=(const Sandbox&) = delete;

  fs::path write(const std::string& name, const std::string& text) const {
    spit(work / name, text);
    return work / name;
  }

  Result run(const std::vector<std::string>& args) const {
    std::string cmd = "cd " + quote(work.string()) + " && " + quote(STICKSLIP_EXE);
    for (const auto& a : args) cmd += " " + quote(a);
    cmd += " >" + quote((root / "stdout").string()) + " 2>" + quote((root / "stderr").string());
    const int status = std::system(cmd.c_str());
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return {code, slurp(root / "stdout"), slurp(root / "stderr")};
  }

  // Every file and directory under `work`, with the contents of the files.
  std::map<std::string, std::string> snapshot() const {
    std::map<std::string, std::string> all;
    for (const auto& e : fs::recursive_directory_iterator(work))
      all[fs::relative(e.path(), work).string()] =
          e.is_directory() ? std::string("<dir>") : slurp(e.path());
    return all;
  }
};

}  // namespace stickslip::test
