// Live haptics (`sphaptics run --interactive`): the bridge backend against a real
// `sphaptics-bridge` child process (simulated device) on 127.0.0.1, device failures (exit 3),
// settings changed while running (LiveControls, commands piped to stdin), haptics.csv in live mode,
// the per-tick recording and its errors. Every loop is bounded in count and time; the live runs are
// 0.4-0.5 s of simulated time on scenes/tests/haptic_drag.yaml (2,900 particles).
#include "cli/runner.h"
#include "haptics/live.h"
#include "haptics/record.h"
#include "haptics/udp.h"
#include "tests/haptics_csv.h"
#include "tests/run_binary.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

using namespace sph;
using sph::testing::TempDir;

namespace {

const std::filesystem::path kSourceDir = SPHAPTICS_SOURCE_DIR;
const std::string kDrag = (kSourceDir / "scenes" / "tests" / "haptic_drag.yaml").string();

using sph::testing::readHaptics;
using sph::testing::Tick;

// Two free UDP ports on 127.0.0.1 (bound, read, released: a small race, fine under ctest -j1).
std::pair<int, int> freePorts() {
  haptics::UdpSocket a, b;
  return {a.port(), b.port()};
}

// `sphaptics-bridge` as a child process, its stdout to a file; stopped with SIGTERM (it prints its
// statistics), killed if it has not exited 3 s later.
struct BridgeProcess {
  pid_t pid = -1;
  std::filesystem::path out;
  BridgeProcess(const std::filesystem::path& dir, int listen, int send, double duration) {
    out = dir / "bridge.txt";
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const std::string l = std::to_string(listen), s = std::to_string(send), d = std::to_string(duration);
    std::vector<std::string> args = {SPHAPTICS_BRIDGE_BINARY, "--listen", l, "--send", s, "--duration", d, "--ramp", "0.1"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid, SPHAPTICS_BRIDGE_BINARY, &fa, nullptr, argv.data(), environ) != 0) pid = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  /// Stops the bridge; its exit status (-1: it had to be killed or was not running).
  int stop() {
    if (pid <= 0) return -1;
    ::kill(pid, SIGTERM);
    int status = 0;
    for (int k = 0; k < 300; ++k) {  // 3 s in 10 ms slices
      if (::waitpid(pid, &status, WNOHANG) == pid) {
        pid = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    pid = -1;
    return -1;
  }
  ~BridgeProcess() { stop(); }
};

}  // namespace

TEST_CASE("Live bridge: a run against sphaptics-bridge grabs the ball, renders forces within limits, logs haptics.csv",
          "[haptics][live][bridge]") {
  // The bridge's simulated hand circles 2 cm around the device origin with button 0 held; the
  // offset puts the ball (radius 2.5 cm at x = 0.25 m) within reach of the target at the start
  // (device (0.02, 0, 0) -> scene x = 0.23 + 2 x 0.02 = 0.27 m: 2 cm from the ball's surface).
  TempDir tmp;
  const auto [bridge_port, listen_port] = freePorts();
  BridgeProcess bridge(tmp.path, bridge_port, listen_port, 60.0);
  REQUIRE(bridge.pid > 0);
  app::RunOptions o;
  o.scene = kDrag;
  o.out = (tmp.path / "out").string();
  o.quiet = true;
  o.duration = 0.5;
  o.interactive = true;
  o.sets = {"haptics.backend=bridge", "haptics.bridge_port=" + std::to_string(bridge_port),
            "haptics.listen_port=" + std::to_string(listen_port), "haptics.bridge_timeout=5",
            "haptics.offset=[0.23, 0.25, 0.25]"};
  const app::RunResult r = app::runScene(o);
  REQUIRE(bridge.stop() == 0);
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
  // States arrived at the bridge's 1 kHz (a third of them at least, on a loaded machine).
  CHECK(r.haptic_ticks > 150);
  const auto rows = readHaptics(tmp.path / "out" / "haptics.csv");
  REQUIRE(rows.size() > 150);
  double fmax = 0, late = 0;
  long held = 0;
  for (const Tick& t : rows) {
    fmax = std::max(fmax, t.f.norm());
    if (t.body == 0) ++held;
    if (t.body == 0) late = std::max(late, t.f.norm());
  }
  INFO("rows " << rows.size() << ", held " << held << ", peak force " << fmax << " N");
  CHECK(held > 50);        // the ball was grabbed over the link
  CHECK(late > 0.01);      // and the hand felt it (0.1 s ramp, then the coupling's pull)
  // The bridge's peak limit; haptics.csv writes 9 significant digits per component, so the norm of
  // the written components may exceed the sent one by up to sqrt(3) * 5e-9 N.
  CHECK(fmax <= 3.0 + 1e-8);
  // The bridge saw the LocalModels (one per frame: 30 frames at 60 fps) and measured their age.
  const std::string said = sph::testing::readFile(bridge.out);
  INFO(said);
  const auto at = said.find("models accepted ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stoi(said.substr(at + 16)) >= 20);
  CHECK(said.find("model age on arrival") != std::string::npos);
}

TEST_CASE("Live bridge: no bridge, or a bridge that stops answering, is a device failure: exit 3, run.json says why",
          "[haptics][live][bridge]") {
  TempDir tmp;
  const auto [bridge_port, listen_port] = freePorts();
  app::RunOptions o;
  o.scene = kDrag;
  o.out = (tmp.path / "none").string();
  o.quiet = true;
  o.duration = 0.5;
  o.interactive = true;
  o.sets = {"haptics.backend=bridge", "haptics.bridge_port=" + std::to_string(bridge_port),
            "haptics.listen_port=" + std::to_string(listen_port), "haptics.bridge_timeout=0.3",
            "haptics.offset=[0.23, 0.25, 0.25]"};
  // Nobody listening: the first State never comes.
  const app::RunResult none = app::runScene(o);
  CHECK(none.exit_code == 3);
  CHECK(none.message.find("bridge 127.0.0.1:" + std::to_string(bridge_port)) != std::string::npos);
  const std::string json = sph::testing::readFile(tmp.path / "none" / "run.json");
  CHECK(json.find("\"failed\"") != std::string::npos);
  CHECK(json.find("no State from sphaptics-bridge") != std::string::npos);

  // The bridge is killed after frame 3: within the 0.3 s timeout the run fails, naming it.
  BridgeProcess bridge(tmp.path, bridge_port, listen_port, 60.0);
  REQUIRE(bridge.pid > 0);
  o.out = (tmp.path / "killed").string();
  o.record = (tmp.path / "killed.rec").string();  // a run that fails leaves no recording, not even an empty one
  const pid_t pid = bridge.pid;
  const app::RunResult killed = app::runScene(o, [&](Simulation&, const FrameReport& rep) {
    if (rep.frame == 3) ::kill(pid, SIGKILL);
  });
  bridge.stop();
  CHECK(killed.exit_code == 3);
  CHECK(killed.message.find("stopped answering") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(o.record));
  CHECK_FALSE(std::filesystem::exists(o.record + ".partial"));
}

TEST_CASE("Live: `sphaptics run --interactive` with backend bridge in batch is refused, exit 2", "[haptics][live][bridge]") {
  TempDir tmp;
  const auto r = sph::testing::sphaptics(tmp.path, {"run", kDrag, "-o", "out", "--set", "haptics.backend=bridge", "-q"});
  CHECK(r.code == 2);
  CHECK(r.err.find("--interactive") != std::string::npos);
}

TEST_CASE("Live controls: commands are parsed, refused with a reason, and scheduled ones land at a frame boundary",
          "[haptics][live]") {
  haptics::LiveSettings init;
  init.gain = 1.0;
  init.scale = 2.0;
  haptics::LiveControls c(init);
  haptics::LiveSettings s;
  CHECK(c.take(0.0, s));  // the initial settings count as a change once
  CHECK_FALSE(c.take(0.0, s));
  CHECK(c.command("gain 0.5").empty());
  CHECK(c.command("scale 3").empty());
  CHECK(c.command("offset 0.1 0.2 0.3").empty());
  CHECK(c.command("smoothing rolling_average 12").empty());
  CHECK(c.command("at 0.5 gain 0").empty());
  CHECK(c.command("# a comment").empty());
  CHECK(c.command("gain -1").find(">= 0") != std::string::npos);
  CHECK(c.command("scale 0").find("> 0") != std::string::npos);
  CHECK(c.command("offset 1 2").find("three numbers") != std::string::npos);
  CHECK(c.command("smoothing rolling_average 0").find("1-1000") != std::string::npos);
  CHECK(c.command("gain 1 2").find("unexpected") != std::string::npos);
  CHECK(c.command("gian 1").find("unknown command 'gian'") != std::string::npos);
  CHECK(c.command("at -1 gain 0").find("time >= 0") != std::string::npos);
  CHECK(c.take(0.1, s));
  CHECK(s.gain == 0.5);
  CHECK(s.scale == 3.0);
  CHECK(s.offset == Eigen::Vector3d(0.1, 0.2, 0.3));
  CHECK(s.smoothing == haptics::Smoothing::RollingAverage);
  CHECK(s.rolling_window == 12);
  CHECK_FALSE(c.take(0.4, s));  // `at 0.5` not yet due
  CHECK(c.take(0.5, s));
  CHECK(s.gain == 0.0);
  CHECK(c.command("pause").empty());
  CHECK(c.settings().paused);
  CHECK_FALSE(c.quitRequested());
  CHECK(c.command("quit").empty());
  CHECK(c.quitRequested());
}

TEST_CASE("Live: the tick ring hands every record over in order and counts what did not fit", "[haptics][live]") {
  haptics::TickRing ring(4);
  for (uint64_t k = 1; k <= 6; ++k) ring.push({k, {}, {}, true});
  std::vector<haptics::TickRecord> out;
  ring.drain(out);
  REQUIRE(out.size() == 4);
  for (std::size_t i = 0; i < 4; ++i) CHECK(out[i].tick == i + 1);
  CHECK(ring.dropped() == 2);
  ring.push({7, {}, {}, true});
  out.clear();
  ring.drain(out);
  REQUIRE(out.size() == 1);
  CHECK(out[0].tick == 7);
}

TEST_CASE("Live: piped commands change the force in haptics.csv (gain 0: nothing sent) and replay with the recording",
          "[haptics][live]") {
  // haptic_drag.yaml live for 0.5 s with `at 0.2 gain 0` and `at 0.1 scale 2.2` on stdin and
  // --record, the hand's path slowed to 6 s so that the device still moves after the changes
  // whatever the machine's load (a mapping change re-anchors the grasp: it moves nothing by itself). Servo time is never behind simulation time (frames are paced to the wall clock from
  // after the servo's clock starts), so ticks before 0.2 s ran at gain 1: the ball being dragged
  // pulls on the hand. The last 0.1 s of ticks come at least 0.2 s after the switch (the slew
  // limit takes the force to 0 in <= 3 N / 50 N/s = 60 ms): nothing is sent. The recording holds
  // both changes at their frame boundaries; the replay applies them there (identical hashes).
  TempDir tmp;
  const std::string cmd = "cd " + sph::testing::shellQuote(tmp.path.string()) +
                          " && printf 'at 0.1 scale 2.2\\nat 0.2 gain 0\\n' | " + sph::testing::shellQuote(SPHAPTICS_BINARY) +
                          " run " + sph::testing::shellQuote(kDrag) +
                          " --interactive --duration 0.5 -o out --record session.rec --set 'haptics.path[0].end=6' > log.txt 2>&1";
  const int status = std::system(cmd.c_str());
  const std::string log = sph::testing::readFile(tmp.path / "log.txt");
  INFO(log);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  CHECK(log.find("command: at 0.2 gain 0") != std::string::npos);
  const auto rows = readHaptics(tmp.path / "out" / "haptics.csv");
  REQUIRE(rows.size() > 200);
  double before = 0, after = 0;
  for (const Tick& t : rows) {
    if (t.t < 0.2) before = std::max(before, t.f.norm());
    if (t.t > rows.back().t - 0.1) after = std::max(after, t.f.norm());
  }
  INFO("max |F| before the switch " << before << " N, in the last 0.1 s " << after << " N");
  CHECK(before > 0.05);
  CHECK(after < 1e-3);

  // The recording: ticks, steps naming them, the two settings changes; the replay matches.
  const haptics::Recording rec = haptics::readRecording((tmp.path / "session.rec").string());
  CHECK(rec.ticks.size() > 200);
  CHECK(rec.step_ticks.size() == rec.steps.size());
  REQUIRE(rec.settings.size() >= 3);  // the initial settings, scale at 0.1 s, gain at 0.2 s
  CHECK(rec.settings.back().second.gain == 0.0);
  const auto replay = sph::testing::sphaptics(tmp.path, {"replay", "session.rec"});
  INFO(replay.err);
  CHECK(replay.code == 0);
  CHECK(replay.out.find("every state hash equal") != std::string::npos);
  // Without the scale change the replay differs (the recorded settings matter).
  haptics::Recording no_scale = rec;
  no_scale.settings.erase(std::remove_if(no_scale.settings.begin(), no_scale.settings.end(),
                                         [](const auto& p) { return p.second.scale != 2.0; }),
                          no_scale.settings.end());
  REQUIRE(no_scale.settings.size() < rec.settings.size());
  app::RunOptions r;
  r.scene = rec.scene;
  r.sets = rec.sets;
  r.replay = &no_scale;
  r.quiet = true;
  r.write_output = false;
  const app::RunResult bad = app::runScene(r);
  CHECK(bad.exit_code != 0);
  CHECK(bad.message.find("state hash differs") != std::string::npos);
}

TEST_CASE("Recording: bad, truncated and wrong-version files give a located error, exit 2", "[haptics][live]") {
  TempDir tmp;
  const std::string good = "# sphaptics haptic recording v2\nscene /nowhere.yaml\nframes 1\n"
                           "tick 0 0 0 0 0 0 0 0 1\ntick 1 0.001 0 0 0 0 0 0 1\nstep 1\n"
                           "settings 0 1 2 0 0 0 servo 20\nhash 0 0123456789abcdef\nend 2 1 1\n";
  tmp.write("good.rec", good);
  const haptics::Recording rec = haptics::readRecording((tmp.path / "good.rec").string());
  CHECK(rec.ticks.size() == 2);
  REQUIRE(rec.steps.size() == 1);
  CHECK(rec.steps[0].time == 0.001);
  CHECK(rec.settings.size() == 1);
  // Truncated (no end line), a step naming a tick not recorded, a future version, a bad hash.
  tmp.write("truncated.rec", good.substr(0, good.find("end 2")));
  tmp.write("missing.rec", "# sphaptics haptic recording v2\nscene /x.yaml\nframes 0\nstep 5\nend 0 1 0\n");
  tmp.write("version.rec", "# sphaptics haptic recording v9\n");
  tmp.write("hash.rec", "# sphaptics haptic recording v2\nscene /x.yaml\nframes 1\nhash 0 xyz\nend 0 0 1\n");
  // Step hashes: 16 hex digits, and on every step or none.
  tmp.write("stephash.rec", "# sphaptics haptic recording v2\nscene /x.yaml\nframes 0\ntick 0 0 0 0 0 0 0 0 1\n"
                            "step 0 0123456789abcdef\nstep 0 12\nend 1 2 0\n");
  tmp.write("stepmix.rec", "# sphaptics haptic recording v2\nscene /x.yaml\nframes 0\ntick 0 0 0 0 0 0 0 0 1\n"
                           "step 0 0123456789abcdef\nstep 0\nend 1 2 0\n");
  auto error = [&](const char* name) {
    try {
      haptics::readRecording((tmp.path / name).string());
    } catch (const haptics::RecordingError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error("truncated.rec").find("truncated") != std::string::npos);
  CHECK(error("missing.rec").find("missing.rec:4:1: 'step' uses tick 5") != std::string::npos);
  CHECK(error("version.rec").find("version.rec:1:1: recording format 'v9'") != std::string::npos);
  CHECK(error("hash.rec").find("hash.rec:4:1:") != std::string::npos);
  CHECK(error("stephash.rec").find("stephash.rec:6:1: 'step' hash must be 16 hex digits") != std::string::npos);
  CHECK(error("stepmix.rec").find("stepmix.rec:6:1: 'step' lines must all have a hash or none") != std::string::npos);
  // The command line: exit 2 with the location.
  const auto r = sph::testing::sphaptics(tmp.path, {"replay", "truncated.rec"});
  CHECK(r.code == 2);
  CHECK(r.err.find("truncated") != std::string::npos);
  // --record to a file that cannot be written: exit 2 (input), not 1.
  const auto w = sph::testing::sphaptics(tmp.path, {"run", kDrag, "--interactive", "--duration", "0.05", "-o", "out", "-q",
                                                     "--record", (tmp.path / "no" / "such" / "dir" / "x.rec").string()});
  CHECK(w.code == 2);
}

TEST_CASE("Live: an in-process panel gets the session's controls while it runs and loses them at the end",
          "[haptics][live]") {
  // RunOptions::live_controls (the viewer's hook): called with the controls after the session
  // starts, with nullptr before it stops; a quit through them ends the run early, complete.
  app::RunOptions o;
  o.scene = kDrag;
  o.quiet = true;
  o.write_output = false;
  o.duration = 2.0;
  o.interactive = true;
  int given = 0, taken = 0;
  o.live_controls = [&](haptics::LiveControls* c) {
    if (c) {
      ++given;
      c->command("at 0.1 quit");
    } else {
      ++taken;
    }
  };
  const app::RunResult r = app::runScene(o);
  CHECK(r.exit_code == 0);
  CHECK(given == 1);
  CHECK(taken == 1);
  CHECK(r.frames < 120);  // quit at 0.1 s, not the 2 s asked for
}
