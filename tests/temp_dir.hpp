#pragma once
// A fresh temporary directory per test, removed with its contents at scope exit.

#include <cstdlib>
#include <filesystem>
#include <string>

namespace calibd::testing {

class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("CALIBD_TEST_TMP");
    std::filesystem::path root = base ? base : std::filesystem::temp_directory_path().string();
    std::filesystem::create_directories(root);
    std::string templ = (root / "calibd-XXXXXX").string();
    if (::mkdtemp(templ.data()) == nullptr) std::abort();
    path_ = templ;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace calibd::testing
