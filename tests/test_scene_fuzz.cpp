// A scene fuzzer (issue 12): a few hundred mutants of the scenes in scenes/ and scenes/tests/
// (deleted keys, wrong types, extreme numbers, nan/inf, huge sizes, bad enums, broken YAML),
// each loaded and compiled in-process as `sphaptics validate` does, under a memory bound.
// Every mutant must be either valid (exit 0) or bad input with a location (exit 2): never a
// crash, an exception of another kind, std::bad_alloc, or a hang. The seed is fixed, so a
// failure names a mutant that can be reproduced.
#include "cli/commands.h"
#include "core/errors.h"
#include "core/model.h"
#include "io/scene_loader.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

/// Values a hostile but fair user could write (each replaces one scalar).
const std::vector<std::string> kValues = {
    "nan", ".nan", "inf", ".inf", "-.inf", "1e30", "-1e30", "1e308", "-1e308", "9e18", "0", "-0", "-1", "1e-9",
    "1e-300", "2147483648", "-2147483649", "99999999999999999999", "abc", "''", "[]", "[1, 2]", "[1e30, 1e30, 1e30]",
    "{a: 1}", "true", "null", "~", "bogus_enum", "\"x/../../escaped\"", "0x10", "1e7", "100", "-5"};

/// One mutant of `text`: a random mutation of a random line.
std::string mutate(const std::string& text, std::mt19937& rng, std::string& what) {
  std::vector<std::string> lines = splitLines(text);
  // Lines that carry a key (not comments, not blank).
  std::vector<std::size_t> keyed;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto first = lines[i].find_first_not_of(' ');
    if (first != std::string::npos && lines[i][first] != '#') keyed.push_back(i);
  }
  if (keyed.empty()) return text;
  std::size_t i = keyed[std::uniform_int_distribution<std::size_t>(0, keyed.size() - 1)(rng)];
  std::string& line = lines[i];
  auto pick = [&](const std::vector<std::string>& v) { return v[std::uniform_int_distribution<std::size_t>(0, v.size() - 1)(rng)]; };
  int kind = std::uniform_int_distribution<int>(0, 6)(rng);
  std::string factor = pick({"1e6", "1e-6", "1e12", "-1"});
  if (kind == 6) {
    // Sizes that ask for too much: a key that sets a size, a spacing or a speed, scaled so that
    // the scene needs far more particles, cells, steps or surface samples than fit.
    std::vector<std::size_t> sized;
    for (const std::size_t k : keyed)
      for (const char* key : {"particle_spacing:", "radius:", "height:", "max:", "size:", "speed:", "max_particles:", "scale:"})
        if (lines[k].find(key) != std::string::npos) sized.push_back(k);
    if (sized.empty()) return mutate(text, rng, what);
    i = sized[std::uniform_int_distribution<std::size_t>(0, sized.size() - 1)(rng)];
    const bool spacing = lines[i].find("particle_spacing:") != std::string::npos;
    factor = spacing ? pick({"1e-2", "3e-2", "1e-3"}) : pick({"30", "1e2", "1e3", "1e7", "1e30"});
    kind = 4;
  }
  // Strip a trailing comment, so that a replaced value is not commented out.
  auto code = [](const std::string& l) {
    const auto hash = l.find(" #");
    return hash == std::string::npos ? l : l.substr(0, hash);
  };
  switch (kind) {
    case 0: {  // delete the key
      what = "delete line " + std::to_string(i + 1);
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(i));
      break;
    }
    case 1:
    case 2: {  // replace the value after the first ": "
      const std::string c = code(line);
      const auto colon = c.find(": ");
      if (colon == std::string::npos) return mutate(text, rng, what);
      const std::string v = pick(kValues);
      what = "line " + std::to_string(i + 1) + " value -> " + v;
      line = c.substr(0, colon + 2) + v;
      break;
    }
    case 3: {  // replace one number inside the line (a component of a vector, a flow map value)
      std::vector<std::pair<std::size_t, std::size_t>> numbers;
      const std::string c = code(line);
      for (std::size_t p = 0; p < c.size();) {
        if ((std::isdigit(static_cast<unsigned char>(c[p])) || c[p] == '-') && (p == 0 || std::string(" [,:").find(c[p - 1]) != std::string::npos)) {
          std::size_t q = p + 1;
          while (q < c.size() && (std::isalnum(static_cast<unsigned char>(c[q])) || c[q] == '.' || c[q] == '-' || c[q] == '+')) ++q;
          numbers.emplace_back(p, q - p);
          p = q;
        } else {
          ++p;
        }
      }
      if (numbers.empty()) return mutate(text, rng, what);
      const auto [at, len] = numbers[std::uniform_int_distribution<std::size_t>(0, numbers.size() - 1)(rng)];
      const std::string v = pick({"nan", "inf", "-inf", "1e30", "-1e30", "9e18", "1e-12", "0", "-1", "1e7", "abc"});
      what = "line " + std::to_string(i + 1) + " number '" + c.substr(at, len) + "' -> " + v;
      line = c.substr(0, at) + v + c.substr(at + len);
      break;
    }
    case 4: {  // scale every number of the line (huge sizes, tiny spacings)
      what = "line " + std::to_string(i + 1) + " numbers x " + factor;
      std::string out;
      const std::string c = code(line);
      for (std::size_t p = 0; p < c.size();) {
        if (std::isdigit(static_cast<unsigned char>(c[p])) && (p == 0 || std::string(" [,:").find(c[p - 1]) != std::string::npos)) {
          std::size_t q = p;
          while (q < c.size() && (std::isdigit(static_cast<unsigned char>(c[q])) || c[q] == '.' || c[q] == 'e' || c[q] == '-' || c[q] == '+')) ++q;
          char buf[64];
          std::snprintf(buf, sizeof buf, "%.6g", std::atof(c.substr(p, q - p).c_str()) * std::atof(factor.c_str()));
          out += buf;
          p = q;
        } else {
          out += c[p++];
        }
      }
      line = out;
      break;
    }
    default: {  // break the structure: duplicate the line, or shift its indentation
      if (std::uniform_int_distribution<int>(0, 1)(rng)) {
        what = "duplicate line " + std::to_string(i + 1);
        lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(i), line);
      } else {
        what = "indent line " + std::to_string(i + 1);
        line = "   " + line;
      }
    }
  }
  return joinLines(lines);
}

/// What validating one mutant gave.
struct Outcome {
  int code = 0;         ///< 0 valid, 2 bad input, -1 anything else
  std::string problem;  ///< "" when acceptable (valid, or bad input with a line on every issue)
};

/// Validates one scene text in-process, as `sphaptics validate` does.
Outcome validateText(const std::string& text, const fs::path& virtual_path) {
  sph::ResourceLimits limits;
  limits.max_bytes = 256e6;  // the memory bound of the fuzzer (unit: bytes)
  try {
    const sph::SceneSpec spec = sph::io::loadSceneFromString(text, virtual_path.string());
    sph::compile(spec, limits);
    return {0, ""};
  } catch (const sph::InputError& e) {
    for (const sph::InputIssue& issue : e.issues())
      if (issue.line <= 0) return {2, "bad input without a line: " + issue.str()};
    return {2, ""};
  } catch (const std::bad_alloc&) {
    return {-1, "std::bad_alloc"};
  } catch (const std::exception& e) {
    return {-1, std::string("exception: ") + e.what()};
  }
}

}  // namespace

TEST_CASE("fuzz: 400 mutants of the scenes validate or are refused with a location, bounded in time and memory",
          "[fuzz]") {
  // Memory bound: an address-space limit 3 GB above what the process already maps, so that an
  // allocation the resource estimate missed fails (and is reported) instead of swapping.
  rlimit old{};
  getrlimit(RLIMIT_AS, &old);
  long pages = 0;
  {
    std::ifstream statm("/proc/self/statm");
    statm >> pages;
  }
  rlimit bound = old;
  bound.rlim_cur = static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE)) + (3ull << 30);
  if (old.rlim_cur != RLIM_INFINITY && old.rlim_cur < bound.rlim_cur) bound.rlim_cur = old.rlim_cur;
  setrlimit(RLIMIT_AS, &bound);

  std::vector<fs::path> scenes;
  for (const fs::path& dir : {kSourceDir / "scenes", kSourceDir / "scenes" / "tests"})
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".yaml") scenes.push_back(e.path());
  std::sort(scenes.begin(), scenes.end());  // directory order is not fixed; the seed's mutants are
  REQUIRE(scenes.size() >= 20);

  std::mt19937 rng(20261123);
  const int kMutants = 400;
  int valid = 0, refused = 0;
  std::vector<std::string> failures;
  double slowest = 0;
  std::string slowest_what;
  for (int m = 0; m < kMutants; ++m) {
    const fs::path& scene = scenes[static_cast<std::size_t>(m) % scenes.size()];
    std::string what;
    const std::string text = mutate(readText(scene), rng, what);
    const auto t0 = std::chrono::steady_clock::now();
    const Outcome o = validateText(text, scene);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (seconds > slowest) slowest = seconds, slowest_what = scene.filename().string() + ": " + what;
    // A hang detector, not a speed test: one mutant compiles in well under a second.
    if (seconds > 20.0) failures.push_back(scene.filename().string() + ": " + what + ": took " + std::to_string(seconds) + " s");
    if (!o.problem.empty()) failures.push_back(scene.filename().string() + ": " + what + ": " + o.problem);
    valid += o.code == 0;
    refused += o.code == 2;
  }
  setrlimit(RLIMIT_AS, &old);
  WARN(valid << " valid, " << refused << " refused; slowest " << slowest << " s (" << slowest_what << ")");
  for (const std::string& f : failures) UNSCOPED_INFO(f);
  CHECK(failures.empty());
  // The mutants exercise both outcomes (a fuzzer whose mutants all fail to parse tests little).
  CHECK(valid >= 40);
  CHECK(refused >= 200);
}

TEST_CASE("fuzz: the validate command's exit codes on a few mutants", "[fuzz]") {
  // The command itself: 0 for a valid scene, 2 for bad input, via validateCommand's streams.
  sph::testing::TempDir tmp;
  const fs::path good = kSourceDir / "scenes" / "tests" / "tiny_tank.yaml";
  const fs::path bad = tmp.write("bad.yaml", "fluid:\n  particle_spacing: nan\n");
  std::ostringstream out, err;
  CHECK(sph::app::validateCommand({good.string()}, 0, out, err) == 0);
  CHECK(sph::app::validateCommand({bad.string()}, 0, out, err) == 2);
  CHECK(err.str().find("bad.yaml:2:") != std::string::npos);
}
