#include "cli/commands.h"

#include "core/cl_context.h"
#include "core/errors.h"
#include "core/model.h"
#include "io/scene_loader.h"
#include "io/schema.h"

#include <iostream>

namespace sph::app {

int validateCommand(const std::vector<std::string>& files) {
  int code = kExitOk;
  for (const std::string& f : files) {
    try {
      const SceneSpec spec = io::loadScene(f);
      const Compiled c = compile(spec);
      std::cout << f << ": ok (" << c.initial.size() << " fluid particles, " << c.model.boundary.size()
                << " boundary particles, stages: " << c.model.stages.str() << ")\n";
    } catch (const InputError& e) {
      std::cerr << e.what() << "\n";
      code = kExitBadInput;
    }
  }
  return code;
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
