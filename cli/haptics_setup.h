// Wiring the `haptics` scene section to the haptics library: device backend, servo settings,
// workspace mapping and the grabbable bodies (cli/ is the only place that joins core, io and haptics).
#pragma once

#include "core/model.h"
#include "haptics/backends.h"
#include "haptics/bridge_client.h"
#include "haptics/live.h"
#include "haptics/mouse.h"
#include "haptics/record.h"
#include "haptics/session.h"

#include <memory>

namespace sph::app {

/// The servo settings of a scene's `haptics` section.
haptics::ServoConfig servoConfig(const HapticsSpec& h);
/// The scripted path (device frame) of a scene's `haptics` section.
haptics::Trajectory hapticPath(const HapticsSpec& h);
/// x_scene = scale R x_device + offset, with the automatic scale (largest domain extent / 0.15 m).
haptics::Mapping hapticMapping(const SceneSpec& spec);
/// A batch (virtual-time) session for a compiled model whose scene has a `haptics` section.
/// With `mouse`, the device is the mouse backend fed by that queue instead of the scene's backend.
std::unique_ptr<haptics::BatchSession> makeBatchSession(const Model& model,
                                                        std::shared_ptr<haptics::MouseInput> mouse = nullptr);
/// A live source for `sphaptics run --interactive`, not started: the servo thread here against a
/// scripted or simulated device (or, with `mouse`, the mouse backend) on the steady clock, or
/// (backend: bridge) the UDP link to a running sphaptics-bridge whose servo runs next to the device.
std::unique_ptr<haptics::LiveSource> makeLiveSession(const Model& model,
                                                     std::shared_ptr<haptics::MouseInput> mouse = nullptr);
/// The replay of a recording's device readings through the model's grab logic (`sphaptics replay`).
std::unique_ptr<haptics::ReplaySource> makeReplaySource(const Model& model, const haptics::Recording& rec);

}  // namespace sph::app
