#include "io/run_lock.h"

#include "core/errors.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace sph::io {

namespace {

std::string hostName() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string utcNow() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// Creates `path` exclusively and writes `text` into it. Returns 0, or the errno of the failure
/// (EEXIST: another lock is there). A failed write removes the file again.
int createExclusive(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return errno;
  const ssize_t n = ::write(fd, text.data(), text.size());
  const int err = n == static_cast<ssize_t>(text.size()) ? 0 : (n < 0 ? errno : EIO);
  ::close(fd);
  if (err) ::unlink(path.c_str());
  return err;
}

}  // namespace

std::string LockOwner::str() const {
  return "pid " + std::to_string(pid) + " on host " + host + ", started " + started;
}

LockOwner RunLock::self() {
  LockOwner o;
  o.pid = static_cast<long>(getpid());
  o.host = hostName();
  o.started = utcNow();
  return o;
}

bool RunLock::read(const std::string& path, LockOwner& owner) {
  std::ifstream in(path);
  if (!in) return false;
  std::string line;
  // Format: "pid <n>\nhost <name>\nstarted <time>\n"
  bool have_pid = false;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string key, value;
    s >> key;
    std::getline(s >> std::ws, value);
    if (key == "pid") {
      char* end = nullptr;
      owner.pid = std::strtol(value.c_str(), &end, 10);
      have_pid = end && *end == '\0' && owner.pid > 0;
    } else if (key == "host") {
      owner.host = value;
    } else if (key == "started") {
      owner.started = value;
    }
  }
  return have_pid;
}

std::string RunLock::acquire(const std::string& dir) {
  release();
  const std::string path = (std::filesystem::path(dir) / kRunLockName).string();
  const LockOwner me = self();
  const std::string text = "pid " + std::to_string(me.pid) + "\nhost " + me.host + "\nstarted " + me.started + "\n";
  std::string note;
  // Two attempts: the second only after a stale lock was removed.
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int err = createExclusive(path, text);
    if (err == 0) {
      path_ = path;
      return note;
    }
    if (err != EEXIST)
      throw InputError(dir, 0, 0, "cannot lock the output folder (" + path + "): " + std::strerror(err));
    // The folder has a lock: busy unless its pid is dead on this host.
    LockOwner other;
    if (!read(path, other))
      throw InputError(dir, 0, 0, "the output folder is in use: lock file " + path +
                                      " exists but names no run (remove it if no run is using the folder)");
    const bool same_host = other.host == me.host;
    const bool alive = !same_host || ::kill(static_cast<pid_t>(other.pid), 0) == 0 || errno == EPERM;
    if (alive || attempt > 0)
      throw InputError(dir, 0, 0, "the output folder is in use by another run (" + other.str() + "; lock file " +
                                      path + "): choose another folder with --out, or wait for that run to end");
    // Stale: the run that held it is gone. Take it over (unlink, then create exclusively again,
    // so that of two runs taking over at once only one wins).
    ::unlink(path.c_str());
    note = "took over the stale lock of a run that no longer exists (" + other.str() + ")";
  }
  return note;  // not reached
}

void RunLock::release() {
  if (path_.empty()) return;
  ::unlink(path_.c_str());
  path_.clear();
}

RunLock::~RunLock() { release(); }

}  // namespace sph::io
