// The OpenHaptics backend (3D Systems Touch and other HDAPI devices) for `sphaptics-bridge`.
// Built only when CMake finds the vendor's HD/hd.h and libHD (never vendored, never needed by
// the tests); without them makeOpenHapticsDevice() is not compiled and the bridge refuses
// `--device touch`. No HDAPI type appears here, so the bridge compiles either way.
#pragma once

#include "haptics/device.h"

#include <memory>
#include <string>

namespace sph::haptics {

/// An HDAPI device by its configured name ("" = HD_DEFAULT_DEVICE). open() throws DeviceError
/// with the HDAPI error text when the device cannot be initialised.
std::unique_ptr<Device> makeOpenHapticsDevice(const std::string& name);

}  // namespace sph::haptics
