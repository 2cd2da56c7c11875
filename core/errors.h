// Errors in three tiers (see DESIGN.md section 5).
//  1. Bad input: InputError (scene, mesh, CLI), carries one or more located messages; exit code 2.
//  2. Bugs: SPH_ASSERT, alive in every build type.
//  3. Numerical trouble: NumericalError, raised by the diagnostics under policy 'abort'; exit code 4.
// Device failures (OpenCL) are DeviceError; exit code 3.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace sph {

enum ExitCode : int { kExitOk = 0, kExitBadInput = 2, kExitDevice = 3, kExitNumerical = 4 };

/// One located problem in an input file: "file:line:col: message".
struct InputIssue {
  std::string file;
  int line = 0;  ///< 1-based; 0 = unknown
  int col = 0;   ///< 1-based; 0 = unknown
  std::string message;
  std::string str() const;
};

/// Bad input: every problem found, not just the first.
class InputError : public std::runtime_error {
 public:
  explicit InputError(std::vector<InputIssue> issues);
  InputError(const std::string& file, int line, int col, const std::string& message);
  const std::vector<InputIssue>& issues() const { return issues_; }

 private:
  std::vector<InputIssue> issues_;
};

/// OpenCL or device failure; the message names the OpenCL error code.
class DeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Numerical failure under policy 'abort'; the message names frame, time, stage and particle.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A stop was asked for (Simulation::setInterrupt's flag) in the middle of a frame: the frame is left
/// unfinished, so the caller ends the run as interrupted and does not use the state as a frame.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void assertFailed(const char* cond, const char* file, int line, const std::string& msg);

}  // namespace sph

#define SPH_ASSERT(cond, msg)                                        \
  do {                                                               \
    if (!(cond)) ::sph::assertFailed(#cond, __FILE__, __LINE__, msg); \
  } while (0)
