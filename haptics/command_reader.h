// Live commands from a terminal or a pipe (`sphaptics run --interactive`): a thread reads lines
// from a file descriptor (polling, so that it can be stopped; never blocks the simulation) and
// hands each to LiveControls::command(); a refused command is answered on the error stream.
//
//   printf 'gain 0.5\nat 2 offset 0 0 0.1\n' | sphaptics run scene.yaml --interactive
#pragma once

#include "haptics/live.h"

#include <atomic>
#include <functional>
#include <string>
#include <thread>

namespace sph::haptics {

class CommandReader {
 public:
  /// Starts reading `fd`; each line goes to `controls`; `reply` gets one line per command.
  CommandReader(LiveControls& controls, int fd, std::function<void(const std::string&)> reply);
  ~CommandReader();  ///< stops and joins (within one poll slice, 50 ms)
  CommandReader(const CommandReader&) = delete;
  CommandReader& operator=(const CommandReader&) = delete;
  /// True when `fd` is a terminal or a pipe (what live mode reads commands from).
  static bool wanted(int fd);

 private:
  void loop();
  LiveControls& controls_;
  int fd_;
  std::function<void(const std::string&)> reply_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

}  // namespace sph::haptics
