#include "core/errors.h"

#include "core/scene_spec.h"

#include <cstdio>
#include <cstdlib>

namespace sph {

std::string SourceLoc::str() const {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line) + ":" + std::to_string(col);
}

std::string InputIssue::str() const {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line) + ":" + std::to_string(col);
  return s.empty() ? message : s + ": " + message;
}

static std::string joinIssues(const std::vector<InputIssue>& issues) {
  std::string s;
  for (const auto& i : issues) {
    if (!s.empty()) s += "\n";
    s += "error: " + i.str();
  }
  return s;
}

InputError::InputError(std::vector<InputIssue> issues)
    : std::runtime_error(joinIssues(issues)), issues_(std::move(issues)) {}

InputError::InputError(const std::string& file, int line, int col, const std::string& message)
    : InputError(std::vector<InputIssue>{InputIssue{file, line, col, message}}) {}

void assertFailed(const char* cond, const char* file, int line, const std::string& msg) {
  std::fprintf(stderr, "sphaptics: internal error (bug) at %s:%d: assertion '%s' failed: %s\n", file, line, cond,
               msg.c_str());
  std::abort();
}

}  // namespace sph
