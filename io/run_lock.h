// One run per output folder: a lock file that names the run holding the folder.
//
// `sphaptics run` takes the lock before it touches anything in the folder, and releases it when
// the run ends (whatever the end: complete, failed, interrupted). The lock is a file created with
// O_CREAT | O_EXCL (atomic), holding "pid host start-time", on which the run holds an flock() for
// its whole life; the kernel drops the flock when the process dies, however it dies.
//
// A second run that finds the file tries the flock: held -> the folder is busy, the run stops
// before writing anything, naming the other run. Free -> the run that wrote the file is gone,
// unless the file names a pid that is alive on this host or another host (an older version
// without the flock, or a run elsewhere on a shared file system): then it is busy too. Otherwise
// the lock is stale (a run that was killed) and is taken over under the flock, with a note, so
// that of two runs taking over at once exactly one wins.
#pragma once

#include <string>

namespace sph::io {

/// The lock file's name inside an output folder.
inline constexpr const char* kRunLockName = ".sphaptics.lock";

/// Who holds a lock: what the lock file says.
struct LockOwner {
  long pid = 0;            ///< process id (unit: 1)
  std::string host;        ///< host name
  std::string started;     ///< start time, UTC, ISO 8601
  std::string str() const;  ///< "pid 123 on host h, started 2026-01-01T00:00:00Z"
};

class RunLock {
 public:
  RunLock() = default;
  ~RunLock();  ///< release()
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

  /// Takes the lock of folder `dir` (which must exist). Returns "" when the folder was free, or a
  /// note when a stale lock (dead pid on this host) was taken over. Throws InputError naming the
  /// other run when the folder is busy, or naming the OS reason when the file cannot be created.
  std::string acquire(const std::string& dir);
  /// Removes the lock file if this object holds it. Safe to call twice.
  void release();
  bool held() const { return !path_.empty(); }

  /// This process, as a lock file would name it.
  static LockOwner self();
  /// Reads a lock file; false when it cannot be read or parsed.
  static bool read(const std::string& path, LockOwner& owner);
  /// Parses a lock file's text; false when it names no pid.
  static bool parse(const std::string& text, LockOwner& owner);

 private:
  std::string path_;  ///< the lock file while held
  int fd_ = -1;       ///< open and flock()ed while held
};

}  // namespace sph::io
