#include "haptics/command_reader.h"

#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

namespace sph::haptics {

CommandReader::CommandReader(LiveControls& controls, int fd, std::function<void(const std::string&)> reply)
    : controls_(controls), fd_(fd), reply_(std::move(reply)) {
  thread_ = std::thread([this] { loop(); });
}

CommandReader::~CommandReader() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
}

bool CommandReader::wanted(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return false;
  return ::isatty(fd) || S_ISFIFO(st.st_mode);
}

void CommandReader::loop() {
  // Bytes as they come; a command is a whole line. End of input ends the reader (not the run).
  std::string pending;
  char buf[512];
  while (running_.load()) {
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, 50);
    if (ready <= 0) continue;
    if (!(p.revents & (POLLIN | POLLHUP))) return;
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n <= 0 && pending.empty()) return;
    if (n <= 0) pending += '\n';  // a last line without its newline
    else pending.append(buf, static_cast<std::size_t>(n));
    for (std::size_t nl; (nl = pending.find('\n')) != std::string::npos;) {
      const std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      const std::string err = controls_.command(line);
      if (!err.empty()) reply_("command refused: " + err);
      else if (line.find_first_not_of(" \t\r") != std::string::npos && line[line.find_first_not_of(" \t\r")] != '#')
        reply_("command: " + line);
    }
    if (n <= 0) return;
  }
}

}  // namespace sph::haptics
