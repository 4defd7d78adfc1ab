#pragma once
// A directory of the test's own under the system's temporary directory,
// removed with everything in it when the object goes. mkdtemp makes its name
// unique, so two test runs on one machine (two CI jobs, a soak beside ctest)
// never write into, or delete, each other's files.
#include <stdlib.h>  // mkdtemp (POSIX)

#include <cerrno>
#include <filesystem>
#include <string>
#include <system_error>

namespace stickslip::test {

struct TempDir {
  std::filesystem::path path;  // exists, empty at first

  explicit TempDir(const std::string& prefix = "stickslip_test") {
    std::string name = (std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string();
    if (mkdtemp(name.data()) == nullptr)
      throw std::system_error(errno, std::generic_category(), "mkdtemp " + name);
    path = name;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

}  // namespace stickslip::test
