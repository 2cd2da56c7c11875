// OpenCL plumbing: device listing and selection, kernel build failures that name file:line and
// the options, OpenCL error codes by name.
#include "core/cl_context.h"
#include "core/errors.h"

#include <catch2/catch.hpp>

#include <cstdlib>

using namespace sph;

TEST_CASE("Devices are listed and selected by kind or index", "[device]") {
  const auto devices = listDevices();
  REQUIRE(!devices.empty());  // pocl's CPU device at least
  ClContext by_index("0");
  CHECK(by_index.info().name == devices[0].name);
  ClContext cpu("cpu");
  CHECK(!cpu.info().is_gpu);
  CHECK_THROWS_AS(ClContext("99"), DeviceError);
  CHECK_THROWS_AS(ClContext("fastest"), DeviceError);
}

TEST_CASE("A kernel build failure prints the build log with file:line and the options", "[device]") {
  ClContext cl;
  const std::string options = "-cl-std=CL1.2 -DSPH_KERNEL=not_a_kernel -DSPH_LAMINAR=0";
  try {
    cl.buildProgram(options);
    FAIL("the build should fail");
  } catch (const DeviceError& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("CL_BUILD_PROGRAM_FAILURE") != std::string::npos);
    CHECK(msg.find(options) != std::string::npos);
    CHECK(msg.find("kernels/density.cl:") != std::string::npos);  // mapped back by #line
  }
}

TEST_CASE("OpenCL error codes are named", "[device]") {
  CHECK(clErrorName(-5) == "CL_OUT_OF_RESOURCES (-5)");
  CHECK(clErrorName(-11) == "CL_BUILD_PROGRAM_FAILURE (-11)");
  CHECK(clErrorName(-9999) == "CL_UNKNOWN_ERROR (-9999)");
}
