#include "io/run_lock.h"

#include "core/errors.h"

#include <fcntl.h>
#include <sys/file.h>
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

/// Reads the whole of an open file from its start ("" on failure).
std::string readAll(int fd) {
  std::string text;
  char buf[512];
  off_t at = 0;
  for (;;) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, at);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    at += n;
  }
  return text;
}

/// Replaces the content of an open file with `text`; 0 or errno.
int rewrite(int fd, const std::string& text) {
  if (::ftruncate(fd, 0) != 0) return errno;
  const ssize_t n = ::pwrite(fd, text.data(), text.size(), 0);
  return n == static_cast<ssize_t>(text.size()) ? 0 : (n < 0 ? errno : EIO);
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
  std::ifstream file(path);
  if (!file) return false;
  std::stringstream text;
  text << file.rdbuf();
  return parse(text.str(), owner);
}

bool RunLock::parse(const std::string& text, LockOwner& owner) {
  std::istringstream in(text);
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
  auto cannot = [&](int err) {
    return InputError(dir, 0, 0, "cannot lock the output folder (" + path + "): " + std::strerror(err));
  };
  auto busy = [&](const LockOwner& other, bool named) {
    return InputError(dir, 0, 0,
                      named ? "the output folder is in use by another run (" + other.str() + "; lock file " + path +
                                  "): choose another folder with --out, or wait for that run to end"
                            : "the output folder is in use: lock file " + path +
                                  " exists but names no run (remove it if no run is using the folder)");
  };
  // A few attempts: a lock released between our open() and flock() is retried.
  for (int attempt = 0; attempt < 3; ++attempt) {
    // A free folder: create the lock file exclusively, flock it, then name this run in it.
    int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
      if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {  // another run took it over in between: it runs
        ::close(fd);
        LockOwner other;
        const bool named = read(path, other);
        throw busy(other, named);
      }
      if (const int err = rewrite(fd, text); err != 0) {
        ::unlink(path.c_str());
        ::close(fd);
        throw cannot(err);
      }
      fd_ = fd;
      path_ = path;
      return "";
    }
    if (errno != EEXIST) throw cannot(errno);

    // A lock file exists. Its run holds an flock on it as long as it lives (the kernel drops the
    // flock when the process dies, however it dies).
    fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) {
      if (errno == ENOENT) continue;  // released in between: try again
      throw cannot(errno);
    }
    LockOwner other;
    const bool named = parse(readAll(fd), other);
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      throw busy(other, named);
    }
    // We hold the flock: its run is gone, unless the file was unlinked meanwhile (then retry).
    struct stat held{}, now{};
    if (::fstat(fd, &held) != 0 || ::stat(path.c_str(), &now) != 0 || held.st_ino != now.st_ino ||
        held.st_dev != now.st_dev) {
      ::close(fd);
      continue;
    }
    // Conservative: a lock that names a live pid on this host, or another host, stays busy (a
    // run of an older version holds no flock); only a dead pid on this host is stale.
    const bool alive = named && (other.host != me.host || ::kill(static_cast<pid_t>(other.pid), 0) == 0 || errno == EPERM);
    if (!named || alive) {
      ::close(fd);
      throw busy(other, named);
    }
    if (const int err = rewrite(fd, text); err != 0) {
      ::close(fd);
      throw cannot(err);
    }
    fd_ = fd;
    path_ = path;
    return "took over the stale lock of a run that no longer exists (" + other.str() + ")";
  }
  throw InputError(dir, 0, 0, "cannot lock the output folder (" + path + "): it changed hands repeatedly; try again");
}

void RunLock::release() {
  if (path_.empty()) return;
  // Unlink while still holding the flock, then close: a run waiting on the old file sees it is
  // no longer at the path (inode check above) and creates a new one.
  ::unlink(path_.c_str());
  ::close(fd_);
  fd_ = -1;
  path_.clear();
}

RunLock::~RunLock() { release(); }

}  // namespace sph::io
