#include "core/cl_context.h"

#include "core/errors.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdlib>
#include <sstream>
#include <utility>

namespace sph {

const std::vector<std::pair<std::string, const char*>>& embeddedKernelFiles();  // kernels/ (generated)

std::string clErrorName(int code) {
  static const std::map<int, const char*> names = {
      {0, "CL_SUCCESS"}, {-1, "CL_DEVICE_NOT_FOUND"}, {-2, "CL_DEVICE_NOT_AVAILABLE"},
      {-3, "CL_COMPILER_NOT_AVAILABLE"}, {-4, "CL_MEM_OBJECT_ALLOCATION_FAILURE"}, {-5, "CL_OUT_OF_RESOURCES"},
      {-6, "CL_OUT_OF_HOST_MEMORY"}, {-7, "CL_PROFILING_INFO_NOT_AVAILABLE"}, {-8, "CL_MEM_COPY_OVERLAP"},
      {-9, "CL_IMAGE_FORMAT_MISMATCH"}, {-10, "CL_IMAGE_FORMAT_NOT_SUPPORTED"}, {-11, "CL_BUILD_PROGRAM_FAILURE"},
      {-12, "CL_MAP_FAILURE"}, {-13, "CL_MISALIGNED_SUB_BUFFER_OFFSET"},
      {-14, "CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST"}, {-15, "CL_COMPILE_PROGRAM_FAILURE"},
      {-16, "CL_LINKER_NOT_AVAILABLE"}, {-17, "CL_LINK_PROGRAM_FAILURE"}, {-18, "CL_DEVICE_PARTITION_FAILED"},
      {-19, "CL_KERNEL_ARG_INFO_NOT_AVAILABLE"}, {-30, "CL_INVALID_VALUE"}, {-31, "CL_INVALID_DEVICE_TYPE"},
      {-32, "CL_INVALID_PLATFORM"}, {-33, "CL_INVALID_DEVICE"}, {-34, "CL_INVALID_CONTEXT"},
      {-35, "CL_INVALID_QUEUE_PROPERTIES"}, {-36, "CL_INVALID_COMMAND_QUEUE"}, {-37, "CL_INVALID_HOST_PTR"},
      {-38, "CL_INVALID_MEM_OBJECT"}, {-39, "CL_INVALID_IMAGE_FORMAT_DESCRIPTOR"}, {-40, "CL_INVALID_IMAGE_SIZE"},
      {-41, "CL_INVALID_SAMPLER"}, {-42, "CL_INVALID_BINARY"}, {-43, "CL_INVALID_BUILD_OPTIONS"},
      {-44, "CL_INVALID_PROGRAM"}, {-45, "CL_INVALID_PROGRAM_EXECUTABLE"}, {-46, "CL_INVALID_KERNEL_NAME"},
      {-47, "CL_INVALID_KERNEL_DEFINITION"}, {-48, "CL_INVALID_KERNEL"}, {-49, "CL_INVALID_ARG_INDEX"},
      {-50, "CL_INVALID_ARG_VALUE"}, {-51, "CL_INVALID_ARG_SIZE"}, {-52, "CL_INVALID_KERNEL_ARGS"},
      {-53, "CL_INVALID_WORK_DIMENSION"}, {-54, "CL_INVALID_WORK_GROUP_SIZE"}, {-55, "CL_INVALID_WORK_ITEM_SIZE"},
      {-56, "CL_INVALID_GLOBAL_OFFSET"}, {-57, "CL_INVALID_EVENT_WAIT_LIST"}, {-58, "CL_INVALID_EVENT"},
      {-59, "CL_INVALID_OPERATION"}, {-60, "CL_INVALID_GL_OBJECT"}, {-61, "CL_INVALID_BUFFER_SIZE"},
      {-62, "CL_INVALID_MIP_LEVEL"}, {-63, "CL_INVALID_GLOBAL_WORK_SIZE"}, {-64, "CL_INVALID_PROPERTY"},
      {-65, "CL_INVALID_IMAGE_DESCRIPTOR"}, {-66, "CL_INVALID_COMPILER_OPTIONS"}, {-67, "CL_INVALID_LINKER_OPTIONS"},
      {-68, "CL_INVALID_DEVICE_PARTITION_COUNT"}, {-1001, "CL_PLATFORM_NOT_FOUND_KHR"}};
  auto it = names.find(code);
  return std::string(it == names.end() ? "CL_UNKNOWN_ERROR" : it->second) + " (" + std::to_string(code) + ")";
}

std::string DeviceInfo::str() const {
  std::ostringstream s;
  s << "device " << index << ": " << name << " [" << (is_gpu ? "GPU" : "CPU") << ", " << compute_units
    << " compute units, " << global_mem / (1024 * 1024) << " MiB] on platform '" << platform << "', driver "
    << driver << ", " << version;
  return s.str();
}

// Enumerate (platform, device) pairs in platform order, then device order.
static std::vector<std::pair<DeviceInfo, cl::Device>> enumerate() {
  std::vector<std::pair<DeviceInfo, cl::Device>> out;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error& e) {
    if (e.err() == -1001) return out;  // no ICD installed: no platforms
    throw DeviceError(std::string("listing OpenCL platforms failed with ") + clErrorName(e.err()));
  }
  for (auto& p : platforms) {
    std::vector<cl::Device> devices;
    try {
      p.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // a platform without devices
    }
    for (auto& d : devices) {
      DeviceInfo info;
      info.index = static_cast<int>(out.size());
      info.platform = p.getInfo<CL_PLATFORM_NAME>();
      info.name = d.getInfo<CL_DEVICE_NAME>();
      info.vendor = d.getInfo<CL_DEVICE_VENDOR>();
      info.driver = d.getInfo<CL_DRIVER_VERSION>();
      info.version = d.getInfo<CL_DEVICE_VERSION>();
      info.is_gpu = (d.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0;
      info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
      info.global_mem = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      out.emplace_back(info, d);
    }
  }
  return out;
}

std::vector<DeviceInfo> listDevices() {
  std::vector<DeviceInfo> out;
  for (auto& [info, dev] : enumerate()) out.push_back(info);
  return out;
}

ClContext::ClContext(const std::string& selector_in) {
  std::string selector = selector_in;
  if (selector.empty()) {
    const char* env = std::getenv("SPHAPTICS_DEVICE");
    if (env) selector = env;
  }
  auto all = enumerate();
  if (all.empty())
    throw DeviceError("no OpenCL device found: is an ICD installed? (Debian: apt-get install pocl-opencl-icd)");

  // Pick the device the selector names.
  const std::pair<DeviceInfo, cl::Device>* pick = nullptr;
  auto first = [&](bool gpu) -> const std::pair<DeviceInfo, cl::Device>* {
    for (auto& e : all)
      if (e.first.is_gpu == gpu) return &e;
    return nullptr;
  };
  if (selector.empty()) {
    pick = first(true);
    if (!pick) pick = first(false);
  } else if (selector == "gpu" || selector == "cpu") {
    pick = first(selector == "gpu");
    if (!pick) throw DeviceError("no OpenCL " + selector + " device found (see `sphaptics devices`)");
  } else {
    char* end = nullptr;
    const long idx = std::strtol(selector.c_str(), &end, 10);
    if (end == selector.c_str() || *end != '\0')
      throw DeviceError("device selector '" + selector + "' is not cpu, gpu or a device index");
    if (idx < 0 || idx >= static_cast<long>(all.size()))
      throw DeviceError("device index " + selector + " out of range: " + std::to_string(all.size()) +
                        " device(s) (see `sphaptics devices`)");
    pick = &all[static_cast<std::size_t>(idx)];
  }
  info_ = pick->first;
  device_ = pick->second;
  clCall("creating the OpenCL context", [&] {
    context_ = cl::Context(device_);
    queue_ = cl::CommandQueue(context_, device_);
    return 0;
  });
}

cl::Program ClContext::buildProgram(const std::string& options) {
  // One translation unit: shared headers first (they define what the kernels use), then kernels.
  std::vector<std::pair<std::string, const char*>> files = embeddedKernelFiles();
  std::stable_sort(files.begin(), files.end(), [](const auto& a, const auto& b) {
    const bool sa = a.first.find("/shared/") != std::string::npos;
    const bool sb = b.first.find("/shared/") != std::string::npos;
    if (sa != sb) return sa;
    if (sa && sb) {  // sim_params.h before the headers that use it
      auto rank = [](const std::string& f) {
        return f.find("sim_params.h") != std::string::npos ? 0 : (f.find("sph_kernel.h") != std::string::npos ? 1 : 2);
      };
      if (rank(a.first) != rank(b.first)) return rank(a.first) < rank(b.first);
    }
    return a.first < b.first;
  });
  std::string source;
  for (auto& [path, text] : files) source += "#line 1 \"" + path + "\"\n" + text + "\n";

  cl::Program program;
  try {
    program = cl::Program(context_, source);
    program.build({device_}, options.c_str());
  } catch (const cl::Error& e) {
    std::string log;
    try {
      log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
    } catch (...) {
    }
    throw DeviceError("building the OpenCL kernels failed with " + clErrorName(e.err()) + "\n  device: " +
                      info_.str() + "\n  options: " + options + "\n  build log:\n" + log);
  }
  return program;
}

KernelSet::KernelSet(ClContext& cl, const std::string& options) : cl_(&cl), program_(cl.buildProgram(options)) {
  std::vector<cl::Kernel> kernels;
  clCall("creating kernels", [&] { return program_.createKernels(&kernels); });
  for (auto& k : kernels) {
    std::string name = k.getInfo<CL_KERNEL_FUNCTION_NAME>();
    name.erase(std::find(name.begin(), name.end(), '\0'), name.end());
    kernels_[name] = k;
  }
}

cl::Kernel& KernelSet::operator[](const std::string& name) {
  auto it = kernels_.find(name);
  SPH_ASSERT(it != kernels_.end(), "no OpenCL kernel named '" + name + "'");
  return it->second;
}

void KernelSet::enqueue(const std::string& name, std::size_t global, std::size_t local) {
  if (global == 0) return;
  cl::Kernel& k = (*this)[name];
  // Per-kernel timing: the queue is drained first, so the time is this kernel's alone.
  std::chrono::steady_clock::time_point t0;
  std::clock_t c0 = 0;
  if (timing_) {
    clCall("waiting for the queue", [&] { return cl_->queue().finish(); });
    t0 = std::chrono::steady_clock::now();
    c0 = std::clock();
  }
  try {
    if (local > 0) {
      global = (global + local - 1) / local * local;
      cl_->queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), cl::NDRange(local));
    } else {
      cl_->queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), cl::NullRange);
    }
  } catch (const cl::Error& e) {
    throw DeviceError("enqueueing kernel '" + name + "' failed with " + clErrorName(e.err()));
  }
  ++counts_[name];
  if (timing_) {
    clCall("waiting for a kernel", [&] { return cl_->queue().finish(); });
    seconds_[name] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cpu_seconds_[name] += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  }
}

}  // namespace sph
