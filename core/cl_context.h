// OpenCL device selection, program building and kernel dispatch (with counts per kernel name).
//
// Device choice: a selector string ("" = default, "cpu", "gpu", or a global device index as listed
// by `sphaptics devices`), else the SPHAPTICS_DEVICE environment variable, else the first GPU if
// any, else the first CPU device (pocl on every machine).
#pragma once

#include <CL/opencl.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace sph {

/// "CL_OUT_OF_RESOURCES (-5)" for an OpenCL error code.
std::string clErrorName(int code);

struct DeviceInfo {
  int index = 0;  ///< global index over all platforms
  std::string platform, name, vendor, driver, version;
  bool is_gpu = false;
  unsigned compute_units = 0;
  uint64_t global_mem = 0;  ///< (unit: bytes)
  std::string str() const;  ///< one line: platform, device, driver
};

/// Every OpenCL device of every platform, in a stable order.
std::vector<DeviceInfo> listDevices();

class ClContext {
 public:
  /// Throws DeviceError when no device matches or the context cannot be created.
  explicit ClContext(const std::string& selector = "");

  const DeviceInfo& info() const { return info_; }
  cl::Context& context() { return context_; }
  cl::CommandQueue& queue() { return queue_; }
  cl::Device& device() { return device_; }

  /// Builds one program from all embedded kernel sources (kernels/shared/*.h first, then
  /// kernels/*.cl, each preceded by a #line directive so that the build log names file:line).
  /// Throws DeviceError with the build log and the options on failure.
  cl::Program buildProgram(const std::string& options);

 private:
  DeviceInfo info_;
  cl::Device device_;
  cl::Context context_;
  cl::CommandQueue queue_;
};

/// The kernels of one program, looked up once by name, with a dispatch counter per kernel.
class KernelSet {
 public:
  KernelSet() = default;
  KernelSet(ClContext& cl, const std::string& options);
  cl::Kernel& operator[](const std::string& name);
  /// Enqueues `name` over `global` work-items and counts it. With `local` > 0 the global size is
  /// rounded up to a multiple of it (the kernel must ignore work-items past its count).
  void enqueue(const std::string& name, std::size_t global, std::size_t local = 0);
  /// Sets the kernel's arguments in order (buffers, scalars, SimParams by value) and enqueues it:
  /// one statement per dispatch, so the argument list reads next to the kernel's signature.
  template <class... Args>
  void call(const std::string& name, std::size_t global, std::size_t local, const Args&... args) {
    cl::Kernel& k = (*this)[name];
    cl_uint index = 0;
    (k.setArg(index++, args), ...);
    enqueue(name, global, local);
  }
  const std::map<std::string, uint64_t>& dispatchCounts() const { return counts_; }
  /// Per-kernel timing (`sphaptics run --profile-kernels`): each dispatch waits for the queue before
  /// and after, and its wall time is added to its kernel's total. Slower; changes no result.
  void setTiming(bool on) { timing_ = on; }
  /// Wall time per kernel name since timing was switched on (unit: s).
  const std::map<std::string, double>& kernelSeconds() const { return seconds_; }
  /// Process CPU time (all threads, the OpenCL CPU driver's included) per kernel name: on a loaded
  /// machine it varies less than the wall time (unit: s).
  const std::map<std::string, double>& kernelCpuSeconds() const { return cpu_seconds_; }

 private:
  ClContext* cl_ = nullptr;
  cl::Program program_;
  std::map<std::string, cl::Kernel> kernels_;
  std::map<std::string, uint64_t> counts_;
  bool timing_ = false;
  std::map<std::string, double> seconds_, cpu_seconds_;
};

/// Runs `fn`, turning a cl::Error into a DeviceError whose message names the code and `what`.
template <class Fn>
auto clCall(const char* what, Fn&& fn) -> decltype(fn());

}  // namespace sph

#include "core/errors.h"

namespace sph {
template <class Fn>
auto clCall(const char* what, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const cl::Error& e) {
    throw DeviceError(std::string(what) + ": " + e.what() + " failed with " + clErrorName(e.err()));
  }
}
}  // namespace sph
