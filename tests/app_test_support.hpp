#pragma once
// Test-only helpers for the app tests: a fixture with a private temporary directory that runs
// the built binaries there, as a user would, and captures their output and exit code.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace sid_test {

struct AppRun {
  int exit_code = -1;  // a crash (signal) leaves -1, which every test rejects
  std::string out;
  std::string err;
};

class AppTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        std::filesystem::temp_directory_path() / (std::string(info->test_suite_name()) + "_" +
                                                  std::to_string(::getpid()) + "_" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(file(name), std::ios::binary) << text;
    return file(name);
  }
  static std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  /// The quoted path of a built app, e.g. app("sid_smooth").
  static std::string app(const std::string& name) { return "'" SID_APP_DIR "/" + name + "'"; }

  /// Runs a shell command line inside the temporary directory.
  AppRun shell(const std::string& command_line) const {
    const std::string out = file("stdout.txt"), err = file("stderr.txt");
    const std::string command =
        "cd '" + dir_.string() + "' && { " + command_line + " ; } >'" + out + "' 2>'" + err + "'";
    const int status = std::system(command.c_str());
    AppRun r;
    if (status != -1 && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
    r.out = read(out);
    r.err = read(err);
    return r;
  }

  std::filesystem::path dir_;
};

}  // namespace sid_test
