#include "cli/commands.h"

#include "core/cl_context.h"
#include "core/errors.h"
#include "core/model.h"
#include "io/scene_loader.h"
#include "io/schema.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <new>

namespace sph::app {

int validateCommand(const std::vector<std::string>& files, double max_memory, std::ostream& out, std::ostream& err) {
  ResourceLimits limits;
  limits.max_bytes = max_memory;
  int code = kExitOk;
  for (const std::string& f : files) {
    try {
      const SceneSpec spec = io::loadScene(f);
      const Compiled c = compile(spec, limits);
      out << f << ": ok (" << c.initial.size() << " fluid particles, " << c.model.boundary.size()
          << " boundary particles, stages: " << c.model.stages.str() << ")\n";
      for (const std::string& w : c.model.warnings) err << "warning: " << w << "\n";
    } catch (const InputError& e) {
      err << e.what() << "\n";
      code = kExitBadInput;
    } catch (const std::bad_alloc&) {  // a bug: the resource estimate should have refused it
      err << f << ": error: out of memory while compiling the scene (the resource estimate missed it)\n";
      code = std::max(code, 1);
    }
  }
  return code;
}

double parseBytes(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !std::isfinite(v) || v <= 0) return -1.0;
  std::string unit(end);
  if (!unit.empty() && (unit.back() == 'B' || unit.back() == 'b')) unit.pop_back();
  double scale = 1.0;
  if (unit.empty()) scale = 1.0;
  else if (unit == "k" || unit == "K") scale = 1e3;
  else if (unit == "M") scale = 1e6;
  else if (unit == "G") scale = 1e9;
  else if (unit == "T") scale = 1e12;
  else if (unit == "Ki") scale = 1024.0;
  else if (unit == "Mi") scale = 1024.0 * 1024.0;
  else if (unit == "Gi") scale = 1024.0 * 1024.0 * 1024.0;
  else if (unit == "Ti") scale = 1024.0 * 1024.0 * 1024.0 * 1024.0;
  else return -1.0;
  return v * scale;
}

int schemaCommand() {
  std::cout << io::schemaText();
  return kExitOk;
}

int devicesCommand() {
  try {
    const auto devices = listDevices();
    if (devices.empty()) {
      std::cerr << "no OpenCL device found (Debian: apt-get install pocl-opencl-icd)\n";
      return kExitDevice;
    }
    for (const DeviceInfo& d : devices) std::cout << d.str() << "\n";
    return kExitOk;
  } catch (const DeviceError& e) {
    std::cerr << "device error: " << e.what() << "\n";
    return kExitDevice;
  }
}

}  // namespace sph::app
