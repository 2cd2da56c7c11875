#include "io/async_writer.h"

#include <chrono>
#include <exception>

namespace sph::io {

using Clock = std::chrono::steady_clock;

AsyncWriter::AsyncWriter(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity), thread_([this] { loop(); }) {}

AsyncWriter::~AsyncWriter() { close(); }

double AsyncWriter::push(std::function<void()> job) {
  const auto t0 = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return jobs_.size() < capacity_ || closing_; });
  if (!closing_ && error_.empty()) jobs_.push_back(std::move(job));
  changed_.notify_all();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string AsyncWriter::error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return error_;
}

double AsyncWriter::busySeconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return busy_;
}

std::string AsyncWriter::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closing_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
  return error();
}

void AsyncWriter::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return !jobs_.empty() || closing_; });
    if (jobs_.empty()) return;  // closing and drained
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    changed_.notify_all();  // room for the producer
    if (!error_.empty()) continue;  // stopped by an earlier failure: drop
    lock.unlock();
    const auto t0 = Clock::now();
    std::string failure;
    try {
      job();
    } catch (const std::exception& e) {
      failure = e.what();
      if (failure.empty()) failure = "writing output failed";
    } catch (...) {
      failure = "writing output failed";
    }
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    lock.lock();
    busy_ += dt;
    if (!failure.empty() && error_.empty()) error_ = failure;
  }
}

}  // namespace sph::io
