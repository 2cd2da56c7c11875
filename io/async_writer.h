// AsyncWriter: output files are written on one background thread, so the simulation never waits
// for the disk (DESIGN.md: exporters on a writer thread). Jobs run in the order they were pushed.
//
// The queue is bounded: push() blocks only when `capacity` jobs are already waiting (the disk is
// slower than the simulation for that many frames), which bounds memory. The first job that
// throws stops the writer: later jobs are dropped, error() reports it, and the run fails. Files
// are written whole (temporary name, then rename), so a stopped writer leaves nothing half-written.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace sph::io {

class AsyncWriter {
 public:
  explicit AsyncWriter(std::size_t capacity = 3);
  ~AsyncWriter();  ///< close()
  AsyncWriter(const AsyncWriter&) = delete;
  AsyncWriter& operator=(const AsyncWriter&) = delete;

  /// Queues a job; blocks while the queue is full. Returns the seconds spent waiting.
  double push(std::function<void()> job);
  /// The first job's error ("" while all went well).
  std::string error() const;
  /// Runs the queued jobs, stops the thread and returns error(). Safe to call twice.
  std::string close();
  /// Seconds the writer thread spent running jobs (unit: s).
  double busySeconds() const;

 private:
  void loop();

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool closing_ = false;
  std::string error_;
  double busy_ = 0;
  std::thread thread_;
};

}  // namespace sph::io
