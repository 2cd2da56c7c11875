// Runs the real `sphaptics` executable (SPHAPTICS_BINARY) through the shell, capturing its exit
// status, stdout and stderr (shared by the CLI-level tests).
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace sph::testing {

namespace fs = std::filesystem;

inline std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// One argument quoted for /bin/sh.
inline std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct Result {
  int code = -1;     ///< exit status; -1 when the process did not exit normally (a crash)
  std::string out;   ///< stdout
  std::string err;   ///< stderr
};

/// Runs `sphaptics args...` in folder `dir` and returns its exit status, stdout and stderr.
inline Result sphaptics(const fs::path& dir, const std::vector<std::string>& args) {
  const fs::path out_file = dir / ".stdout", err_file = dir / ".stderr";
  std::string cmd = "cd " + shellQuote(dir.string()) + " && " + shellQuote(SPHAPTICS_BINARY);
  for (const auto& a : args) cmd += " " + shellQuote(a);
  cmd += " >" + shellQuote(out_file.string()) + " 2>" + shellQuote(err_file.string()) + " </dev/null";
  const int status = std::system(cmd.c_str());
  Result r;
  // The shell reports a child killed by a signal as 128 + signal; count that as a crash too.
  if (status != -1 && WIFEXITED(status) && WEXITSTATUS(status) < 128) r.code = WEXITSTATUS(status);
  r.out = readFile(out_file);
  r.err = readFile(err_file);
  fs::remove(out_file);
  fs::remove(err_file);
  return r;
}

}  // namespace sph::testing
