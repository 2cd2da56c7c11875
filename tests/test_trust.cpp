// Results you can trust (issue 12): one run per output folder, every way a run ends recorded in
// run.json, write errors with the OS reason, warnings counted, --duration checked, bounded
// resources for any input. Runs the real `sphaptics` executable (a second process, signals,
// resource limits) on the tiny tank (480 particles, about 0.5 s per frame on 2 loaded cores).
#include "tests/run_binary.h"
#include "tests/temp_dir.h"

#include "cli/runner.h"
#include "core/model.h"
#include "io/atomic_file.h"
#include "io/run_lock.h"
#include "io/scene_loader.h"

#include <catch2/catch.hpp>

// sphaptics_io keeps HDF5's include folder private; Debian installs the serial headers under
// hdf5/serial/ (as in test_h5part.cpp).
#if __has_include(<hdf5.h>)
#include <hdf5.h>
#else
#include <hdf5/serial/hdf5.h>
#endif

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using sph::testing::readFile;
using sph::testing::Result;
using sph::testing::shellQuote;
using sph::testing::sphaptics;
using sph::testing::TempDir;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;
const fs::path kTinyScene = kSourceDir / "scenes" / "tests" / "tiny_tank.yaml";

bool contains(const std::string& text, const std::string& fragment) { return text.find(fragment) != std::string::npos; }

/// `sphaptics args...` started in the background in `dir` (stdout/stderr to dir/.bg_out, .bg_err).
pid_t startSphaptics(const fs::path& dir, const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    if (chdir(dir.c_str()) != 0) _exit(127);
    const int out = open(".bg_out", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open(".bg_err", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int in = open("/dev/null", O_RDONLY);
    dup2(out, 1), dup2(err, 2), dup2(in, 0);
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(SPHAPTICS_BINARY));
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(SPHAPTICS_BINARY, argv.data());
    _exit(127);
  }
  return pid;
}

/// Waits for `pid`; returns its exit status, or 1000 + signal when a signal killed it.
int waitExit(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

/// Polls until `ready()` holds (every 20 ms, at most `seconds`).
template <class F>
bool waitFor(F ready, double seconds = 60.0) {
  const auto t0 = std::chrono::steady_clock::now();
  while (!ready()) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > seconds) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

/// Number of Step#k groups in an H5Part file; -1 when HDF5 cannot open it.
int h5partSteps(const fs::path& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) return -1;
  int steps = 0;
  while (H5Lexists(file, ("Step#" + std::to_string(steps)).c_str(), H5P_DEFAULT) > 0) ++steps;
  H5Fclose(file);
  return steps;
}

/// A lock file as a run would write it, naming `pid` on this host.
std::string lockText(long pid) {
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  return "pid " + std::to_string(pid) + "\nhost " + host + "\nstarted 2026-01-01T00:00:00Z\n";
}

/// A pid that is certainly dead: a child that has exited and been reaped.
pid_t deadPid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  waitpid(pid, nullptr, 0);
  return pid;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Item 3: one run per output folder; a run touches only its own files
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: a folder locked by a live run is refused before anything in it is touched", "[trust][lock]") {
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  fs::create_directories(out);
  // What the other (live: this test process) run has written so far.
  const std::vector<std::pair<std::string, std::string>> theirs = {
      {sph::io::kRunLockName, lockText(getpid())},
      {"particles.h5part.partial", "their particles\n"},
      {"bodies.csv", "their bodies\n"},
      {"run.json", "{\"status\": \"running\"}\n"},
      {"body_ball_0001.obj", "v 0 0 0\n"},
      {"fluid_water_0001.obj", "v 0 0 0\n"}};
  for (const auto& [name, text] : theirs) std::ofstream(out / name) << text;

  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 2);
  CHECK(contains(r.err, "in use by another run"));
  CHECK(contains(r.err, "pid " + std::to_string(getpid())));
  // Every file of the other run is still there, byte for byte, and nothing was added.
  for (const auto& [name, text] : theirs) CHECK(readFile(out / name) == text);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(out)) ++files;
  CHECK(files == theirs.size());
}

TEST_CASE("trust: a second real run into a busy folder exits 2 and the first completes with a readable file",
          "[trust][lock]") {
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  // Run A: 30 frames of the tiny tank. Once it writes its particles it is paused (SIGSTOP), so
  // that B surely meets it mid-run whatever the machine's load, and resumed after B.
  const pid_t a = startSphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.5", "--quiet"});
  REQUIRE(waitFor([&] { return fs::exists(out / "particles.h5part.partial"); }));
  kill(a, SIGSTOP);
  REQUIRE(fs::exists(out / sph::io::kRunLockName));  // A is still running
  const Result b = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet"});
  kill(a, SIGCONT);
  const int a_code = waitExit(a);
  INFO("B: exit " << b.code << ", stderr:\n" << b.err << "\nA: exit " << a_code << ", stderr:\n" << readFile(tmp.path / ".bg_err"));
  CHECK(b.code == 2);
  CHECK(contains(b.err, "in use by another run (pid " + std::to_string(a)));
  REQUIRE(a_code == 0);
  CHECK(contains(readFile(out / "run.json"), "\"status\": \"complete\""));
  CHECK(h5partSteps(out / "particles.h5part") == 31);  // Step#0 .. Step#30
  CHECK_FALSE(fs::exists(out / sph::io::kRunLockName));  // released at the end
}

TEST_CASE("trust: a run refused after taking the lock leaves the earlier run's files as they were", "[trust][lock]") {
  // A bad --disable is found once the device is up: the folder (an earlier run's outputs) stays
  // untouched and the lock is released.
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  fs::create_directories(out);
  std::ofstream(out / "run.json") << "{\"status\": \"complete\"}\n";
  std::ofstream(out / "particles.h5part") << "earlier frames\n";
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet",
                                        "--disable", "bogus"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(readFile(out / "run.json") == "{\"status\": \"complete\"}\n");
  CHECK(readFile(out / "particles.h5part") == "earlier frames\n");
  CHECK_FALSE(fs::exists(out / sph::io::kRunLockName));
}

TEST_CASE("trust: the lock is held by the flock of a live run, whatever pid its file names", "[trust][lock]") {
  // A lock file naming a dead pid, but flock()ed by a live process (this test): busy.
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  fs::create_directories(out);
  const pid_t dead = deadPid();
  std::ofstream(out / sph::io::kRunLockName) << lockText(dead);
  const int fd = open((out / sph::io::kRunLockName).c_str(), O_RDWR);
  REQUIRE(flock(fd, LOCK_EX | LOCK_NB) == 0);
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(contains(r.err, "in use by another run (pid " + std::to_string(dead)));
  close(fd);
  // In one process: a second RunLock on the folder is refused until the first is released.
  sph::io::RunLock first, second;
  fs::remove(out / sph::io::kRunLockName);
  CHECK(first.acquire(out.string()).empty());
  CHECK_THROWS_WITH(second.acquire(out.string()), Catch::Contains("in use by another run (pid " + std::to_string(getpid())));
  first.release();
  CHECK_FALSE(fs::exists(out / sph::io::kRunLockName));
  CHECK(second.acquire(out.string()).empty());
  CHECK(second.held());
}

TEST_CASE("trust: a stale lock of a dead run is taken over with a note", "[trust][lock]") {
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  fs::create_directories(out);
  const pid_t dead = deadPid();
  std::ofstream(out / sph::io::kRunLockName) << lockText(dead);
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 0);
  const std::string json = readFile(out / "run.json");
  CHECK(contains(json, "took over the stale lock of a run that no longer exists (pid " + std::to_string(dead)));
  CHECK(contains(json, "\"status\": \"complete\""));
  CHECK_FALSE(fs::exists(out / sph::io::kRunLockName));
}

TEST_CASE("trust: a run never renames another run's particles.h5part.partial", "[trust][lock]") {
  // An earlier run was interrupted; this one writes no particles: its .partial stays as it was.
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  fs::create_directories(out);
  std::ofstream(out / "particles.h5part.partial") << "an earlier run's frames\n";
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet",
                                        "--set", "output.particles=false"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 0);
  CHECK_FALSE(fs::exists(out / "particles.h5part"));
  CHECK(readFile(out / "particles.h5part.partial") == "an earlier run's frames\n");
}

// ---------------------------------------------------------------------------------------------
// Item 4: every way a run ends is recorded
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: SIGTERM and SIGHUP end a run like Ctrl-C: exit 128 + signal, run.json interrupted", "[trust][signal]") {
  for (const int sig : {SIGTERM, SIGHUP}) {
    TempDir tmp;
    const fs::path out = tmp.path / "out";
    const pid_t pid = startSphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "10", "--quiet"});
    // Signal once the first frame is on disk (Step#0 is written before the frame loop).
    REQUIRE(waitFor([&] { return fs::exists(out / "particles.h5part.partial") && fs::exists(out / "run.json"); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(pid, sig);
    const int code = waitExit(pid);
    INFO("signal " << sig << ": exit " << code << ", stderr:\n" << readFile(tmp.path / ".bg_err"));
    CHECK(code == 128 + sig);
    const std::string json = readFile(out / "run.json");
    CHECK(contains(json, "\"status\": \"interrupted\""));
    CHECK(contains(json, sig == SIGTERM ? "SIGTERM" : "SIGHUP"));
    CHECK_FALSE(fs::exists(out / "particles.h5part"));
    CHECK(h5partSteps(out / "particles.h5part.partial") >= 1);  // readable, Step#0 at least
    CHECK_FALSE(fs::exists(out / sph::io::kRunLockName));
  }
}

TEST_CASE("trust: a signal stops a run in the middle of a long frame, not at its end", "[trust][signal]") {
  // tiny_tank.yaml at 0.1 frames/s: a frame is 10 simulated seconds, ~27,000 WCSPH steps, ~15 s of
  // wall time here. The step loops read the stop flag before every step (Simulation::setInterrupt,
  // session 16; before, only the frame loop did, and a DFSPH frame whose steps had collapsed ran on for
  // 48 min after SIGTERM). So the run ends interrupted with no frame but Step#0 on disk: had it waited
  // for the frame's end, frame 1 would be written too.
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  const pid_t pid = startSphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--quiet", "--set",
                                              "simulation.frame_rate=0.1", "--set", "simulation.duration=20"});
  REQUIRE(waitFor([&] { return fs::exists(out / "particles.h5part.partial") && fs::exists(out / "run.json"); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(pid, SIGTERM);
  const int code = waitExit(pid);
  INFO("exit " << code << ", stderr:\n" << readFile(tmp.path / ".bg_err"));
  CHECK(code == 128 + SIGTERM);
  CHECK(contains(readFile(out / "run.json"), "\"status\": \"interrupted\""));
  CHECK(h5partSteps(out / "particles.h5part.partial") == 1);  // Step#0 only: no frame finished
}

TEST_CASE("trust: a closed output pipe does not kill the run", "[trust][signal]") {
  // stderr into a pipe whose reader (head) leaves after one byte: the run's later writes fail
  // with EPIPE, and SIGPIPE (default action: die) must not end it.
  TempDir tmp;
  const std::string cmd = "cd " + shellQuote(tmp.path.string()) + " && ( " + shellQuote(SPHAPTICS_BINARY) + " run " +
                          shellQuote(kTinyScene.string()) +
                          " --out out --duration 0.05 2>&1; echo $? > code ) | head -c 1 > /dev/null";
  std::system(cmd.c_str());
  const std::string code = readFile(tmp.path / "code");
  INFO("exit status: " << code);
  CHECK(code == "0\n");
  CHECK(contains(readFile(tmp.path / "out" / "run.json"), "\"status\": \"complete\""));
}

TEST_CASE("trust: a write error names the OS reason, leaves no .tmp and run.json says failed", "[trust][signal]") {
  // Writes that fail as on a full disk: the output files are links to /dev/full (ENOSPC, "No space
  // left on device"), as an earlier run could have left them (a run replaces its own file names).
  TempDir tmp;
  const fs::path out = tmp.path / "out";
  for (const char* name : {"particles.h5part.partial", "run.json.tmp"}) {
    fs::remove_all(out);
    fs::create_directories(out);
    fs::create_symlink("/dev/full", out / name);
    const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.0167", "--quiet"});
    INFO(name << " -> /dev/full: exit " << r.code << ", stderr:\n" << r.err);
    CHECK(r.code == 1);
    CHECK(contains(r.err, "No space left on device"));
    CHECK(contains(readFile(out / "run.json"), "\"status\": \"failed\""));
    CHECK_FALSE(fs::exists(out / "particles.h5part"));
    for (const auto& e : fs::directory_iterator(out)) CHECK(e.path().extension() != ".tmp");
  }
}

TEST_CASE("trust: writeFileAtomic names the OS reason and leaves no temporary file", "[trust]") {
  TempDir tmp;
  // A folder in place of the target: the rename fails after the temporary was written.
  fs::create_directories(tmp.path / "target" / "sub");
  try {
    sph::io::writeFileAtomic((tmp.path / "target").string(), "text");
    FAIL("no exception");
  } catch (const std::runtime_error& e) {
    CHECK(contains(e.what(), "Is a directory"));
  }
  CHECK_FALSE(fs::exists(tmp.path / "target.tmp"));
  // A missing folder: the temporary cannot be created.
  try {
    sph::io::writeFileAtomic((tmp.path / "missing" / "run.json").string(), "text");
    FAIL("no exception");
  } catch (const std::runtime_error& e) {
    CHECK(contains(e.what(), "No such file or directory"));
  }
}

// ---------------------------------------------------------------------------------------------
// Items 4, 6, 7: warnings counted right, also under --quiet; one line to act on, a summary
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: a time step above the CFL limit is counted as such, in run.json and under --quiet", "[trust][warnings]") {
  // One step per frame at 60 fps under time_step_control: warn. CFL limit (Monaghan 1992):
  // dt <= cfl h / (c0 + |v|) = 0.4 x 0.01 m / 10.85 m/s = 3.69e-4 s, so the 1/60 s step is at least
  // 45.2 x over (|v| > 0 only raises it). Before the fix this was reported as 0 CFL violations.
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.05", "--quiet",
                                        "--set", "simulation.time_step_control=warn", "--set", "simulation.substeps=1",
                                        "--set", "simulation.numerical_errors=warn"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  REQUIRE(r.code == 0);
  const std::string json = readFile(tmp.path / "out" / "run.json");
  INFO(json);
  CHECK(contains(json, "\"cfl_step_frames\": 3"));
  std::smatch m;
  REQUIRE(std::regex_search(json, m, std::regex("\"max_step_over_cfl_limit\": ([0-9.e+]+)")));
  const double over = std::stod(m[1]);
  const double c0 = 10.0 * std::sqrt(2.0 * 9.81 * 0.06);  // compile(): 10 x the block's free-fall speed
  CHECK(over >= (1.0 / 60.0) / (0.4 * 0.01 / c0) * (1.0 - 1e-6));
  // What a user must act on is printed once, also under --quiet; the rest is counted.
  std::size_t lines = 0;
  for (std::size_t p = r.err.find("x the CFL limit"); p != std::string::npos; p = r.err.find("x the CFL limit", p + 1)) ++lines;
  CHECK(lines == 1);
  CHECK(contains(r.err, "warning: frame 0 t=0.0166667 s: time step 0.0166667 s is "));
}

// ---------------------------------------------------------------------------------------------
// Item 6: --duration does what it says
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: --duration must be a finite time of at least half a frame", "[trust][duration]") {
  TempDir tmp;
  for (const std::string bad : {"-1", "nan", "inf", "0.005"}) {
    const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", bad, "--quiet"});
    INFO("--duration " << bad << ": exit " << r.code << ", stderr:\n" << r.err);
    CHECK(r.code == 2);
    CHECK(contains(r.err, "--duration"));
    CHECK_FALSE(fs::exists(tmp.path / "out" / "particles.h5part"));
  }
  // Not a whole number of frames: said, with what is simulated instead.
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.025"});
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(contains(r.err, "is not a whole number of frames at 60 fps: simulating 2 frame(s)"));
  // The scene's key, shorter than half a frame: refused at its section's location.
  tmp.write("short.yaml", "simulation:\n  duration: 0.001\n" + readFile(kTinyScene).substr(readFile(kTinyScene).find("\ndomain:")));
  const Result v = sphaptics(tmp.path, {"validate", "short.yaml"});
  INFO(v.err);
  CHECK(v.code == 2);
  CHECK(contains(v.err, "short.yaml:2:13: 'simulation.duration' 0.001 s is shorter than half a frame"));
}

// ---------------------------------------------------------------------------------------------
// Item 5: bounded resources for any input
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: oversized scenes and non-regular files exit 2 at once with a location, memory bounded", "[trust][resources]") {
  // Each under a 2 GB address-space limit and a 30 s timeout (before the fix: 120 s and 7.4 GB,
  // then std::bad_alloc; /dev/zero never ended).
  TempDir tmp;
  const std::string head = "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n";  // line 1
  const std::string fluid = "fluid:\n  particle_spacing: 0.01\n  phases: [{name: water}]\n";  // lines 2-4
  struct Case {
    std::string name, text, where, what;
  };
  const std::vector<Case> cases = {
      {"spacing.yaml", head + "fluid:\n  particle_spacing: 1e-4\n  phases: [{name: water}]\n  blocks: [{min: [0, 0, 0], max: [0.5, 0.5, 0.5]}]\n",
       "spacing.yaml:5:12:", "the scene needs about"},
      {"cylinder.yaml", head + fluid + "  blocks: [{min: [0, 0, 0], max: [0.5, 0.5, 0.5]}]\nrigid_bodies:\n"
       "  - {name: c, shape: cylinder, radius: 0.1, height: 100, position: [0.5, 0.5, 0.5], dynamic: true, density: 500}\n",
       "cylinder.yaml:7:5:", "too large for the particle spacing"},
      {"domain.yaml", "domain: {min: [0, 0, 0], max: [9e18, 1, 1]}\n" + fluid + "  blocks: [{min: [0, 0, 0], max: [0.5, 0.5, 0.5]}]\n",
       "domain.yaml:1:1:", "the scene needs about"},
      {"nozzle.yaml", head + fluid + "  inflows: [{name: n, position: [0.5, 0.5, 0.9], radius: 1e7, speed: 1}]\n",
       "nozzle.yaml:5:13:", "the scene needs about"},
      {"speed.yaml", head + fluid + "  max_particles: 1000\n  inflows: [{name: n, position: [0.5, 0.5, 0.9], radius: 0.1, speed: 1e30}]\n",
       "speed.yaml:2:1:", "time steps (limit 100000)"},
  };
  for (const Case& c : cases) tmp.write(c.name, c.text);
  mkfifo((tmp.path / "fifo.yaml").c_str(), 0644);
  auto validate = [&](const std::string& file) {
    const std::string cmd = "cd " + shellQuote(tmp.path.string()) + " && ulimit -v 2000000 && timeout 30 " +
                            shellQuote(SPHAPTICS_BINARY) + " validate " + shellQuote(file) + " 2> err; echo $? > code";
    std::system(cmd.c_str());
    return std::make_pair(readFile(tmp.path / "code"), readFile(tmp.path / "err"));
  };
  for (const Case& c : cases) {
    const auto [code, err] = validate(c.name);
    INFO(c.name << ": exit " << code << "stderr:\n" << err);
    CHECK(code == "2\n");
    CHECK(contains(err, c.where));
    CHECK(contains(err, c.what));
  }
  for (const std::string file : {"/dev/zero", "fifo.yaml"}) {
    const auto [code, err] = validate(file);
    INFO(file << ": exit " << code << "stderr:\n" << err);
    CHECK(code == "2\n");
    CHECK(contains(err, "not a regular file"));
  }
  // --max-memory: the tiny tank's few MB fit in 1G, not in 1M.
  const Result fits = sphaptics(tmp.path, {"validate", kTinyScene.string(), "--max-memory", "1G"});
  CHECK(fits.code == 0);
  const Result tight = sphaptics(tmp.path, {"validate", kTinyScene.string(), "--max-memory", "1M"});
  INFO(tight.err);
  CHECK(tight.code == 2);
  CHECK(contains(tight.err, "more than --max-memory 1 MB"));
  const Result junk = sphaptics(tmp.path, {"validate", kTinyScene.string(), "--max-memory", "lots"});
  CHECK(junk.code == 2);
}

TEST_CASE("trust: the memory estimate bounds what a run allocates on the device", "[trust][resources]") {
  // The estimate is meant as an upper bound of host + device memory: at least the device part
  // that Simulation::deviceBytes() counts, and within 20x of it (a useful estimate).
  for (const char* scene : {"tiny_tank.yaml", "floating_block.yaml"}) {
    sph::app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / scene).string();
    o.quiet = true;
    o.write_output = false;
    o.duration = 1.0 / 60.0;
    const sph::app::RunResult res = sph::app::runScene(o);
    REQUIRE(res.exit_code == 0);
    const sph::SceneSpec spec = sph::io::loadScene(o.scene);
    const sph::ResourceEstimate est = sph::estimateResources(spec);
    INFO(scene << ": estimate " << est.str() << ", device bytes " << res.device_bytes);
    CHECK(est.bytes >= static_cast<double>(res.device_bytes));
    CHECK(est.bytes <= 20.0 * static_cast<double>(res.device_bytes));
  }
}

TEST_CASE("trust: the memory estimate bounds what a DFSPH run allocates on the device", "[trust][resources][dfsph]") {
  // The same rule with `fluid.solver: dfsph`, whose extrapolated walls keep per wall particle two
  // pressures and this step's list of fluid neighbours with their weights (core/dfsph.cpp), and
  // whose two-level solve keeps per fluid particle its coarse-grid pair sums: the estimate must
  // still be at least the device memory the run allocates, for every `walls` and with the
  // coarse correction on.
  for (const char* scene : {"tiny_tank.yaml", "floating_block.yaml"})
    for (const char* extra : {"fluid.dfsph.walls=extrapolated", "fluid.dfsph.walls=single", "fluid.dfsph.coarse_interval=4"}) {
      sph::app::RunOptions o;
      o.scene = (kSourceDir / "scenes" / "tests" / scene).string();
      o.quiet = true;
      o.write_output = false;
      o.duration = 1.0 / 60.0;
      o.sets = {"fluid.solver=dfsph", extra};
      const sph::app::RunResult res = sph::app::runScene(o);
      REQUIRE(res.exit_code == 0);
      const sph::ResourceEstimate est = sph::estimateResources(sph::io::loadScene(o.scene, o.sets));
      INFO(scene << " with " << extra << ": estimate " << est.str() << ", device bytes " << res.device_bytes);
      CHECK(est.bytes >= static_cast<double>(res.device_bytes));
      CHECK(est.bytes <= 20.0 * static_cast<double>(res.device_bytes));
    }
}

// ---------------------------------------------------------------------------------------------
// Item 6: inputs that are accepted do what they say
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: body names that are not safe file names, and dynamic bodies outside the domain, are refused at their keys",
          "[trust][bodies]") {
  TempDir tmp;
  const std::string scene =
      "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"                                                    // 1
      "fluid:\n  particle_spacing: 0.05\n  blocks: [{min: [0, 0, 0], max: [1, 1, 0.3]}]\n"             // 2-4
      "rigid_bodies:\n"                                                                              // 5
      "  - {name: x/../../escaped, shape: sphere, radius: 0.1, position: [0.5, 0.5, 0.6], density: 500}\n"  // 6
      "  - {name: .hidden, shape: sphere, radius: 0.1, position: [0.2, 0.2, 0.6], density: 500}\n"    // 7
      "  - {name: away, shape: sphere, radius: 0.1, position: [0.5, 0.5, 5], density: 500, dynamic: true}\n";  // 8
  tmp.write("bodies.yaml", scene);
  const Result r = sphaptics(tmp.path, {"validate", "bodies.yaml"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(contains(r.err, "bodies.yaml:6:12: rigid body name 'x/../../escaped' is used in file names"));
  CHECK(contains(r.err, "bodies.yaml:7:12: rigid body name '.hidden' is used in file names"));
  CHECK(contains(r.err, "bodies.yaml:8:56: rigid body 'away' is dynamic but starts outside the domain"));
}

// ---------------------------------------------------------------------------------------------
// Item 7: messages say what the code does today
// ---------------------------------------------------------------------------------------------

TEST_CASE("trust: a frame with only repaired wall crossings prints no warning line, and the summary and run.json count them",
          "[trust][warnings]") {
  // The tiny tank thrown at the x_max wall and the floor at 4 m/s: particles cross the walls and
  // are put back (a repair, nothing to act on). Before: one "warning: frame ..." line per frame.
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0.05", "--set",
                                        "fluid.blocks[0].velocity=[4, 0, -4]"});
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_FALSE(contains(r.err, "warning: frame"));
  std::smatch m;
  REQUIRE(std::regex_search(r.err, m, std::regex("warnings: ([0-9]+) wall crossing\\(s\\) in ([0-9]+) frame\\(s\\)")));
  const std::string json = readFile(tmp.path / "out" / "run.json");
  CHECK(contains(json, "\"wall_crossings\": " + m[1].str()));
  CHECK(std::stoi(m[1]) > 0);
}

TEST_CASE("trust: the moving-body note and the bodies.csv header describe today's coupling", "[trust][messages]") {
  // Viscous coupling (kernels/rigid.cl, sph_boundary_viscosity) and contact between bodies
  // (core/contact.h) exist: no message may say they do not.
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"run", (kSourceDir / "scenes" / "tests" / "floating_block.yaml").string(), "--out",
                                        "out", "--duration", "0.034"});
  INFO(r.err);
  REQUIRE(r.code == 0);
  const std::string csv = readFile(tmp.path / "out" / "bodies.csv");
  for (const std::string& text : {r.err, csv, readFile(tmp.path / "out" / "run.json")}) {
    CHECK_FALSE(contains(text, "no viscous coupling"));
    CHECK_FALSE(contains(text, "none between bodies"));
  }
  CHECK(contains(r.err, "coupled to the fluid by pressure, viscosity and contact"));
  CHECK(contains(csv, "viscous"));
}

TEST_CASE("trust: README names exactly the scenes that have an output.isosurface section", "[trust][messages]") {
  const std::string readme = readFile(kSourceDir / "README.md");
  const auto from = readme.find("Of the scenes in `scenes/`,");
  REQUIRE(from != std::string::npos);
  const std::string sentence = readme.substr(from, readme.find("have the section", from) - from);
  std::set<std::string> claimed, actual;
  const std::regex name("`([a-z_]+\\.yaml)`");
  for (auto it = std::sregex_iterator(sentence.begin(), sentence.end(), name); it != std::sregex_iterator(); ++it)
    claimed.insert((*it)[1]);
  for (const auto& e : fs::directory_iterator(kSourceDir / "scenes"))
    if (e.path().extension() == ".yaml" && sph::io::loadScene(e.path().string()).output.isosurface.enabled)
      actual.insert(e.path().filename().string());
  CHECK(claimed == actual);
}
