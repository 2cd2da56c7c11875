// Scene files: YAML -> SceneSpec, validated against the schema table (io/schema.h).
#pragma once

#include "core/scene_spec.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sph::io {

/// The largest scene file read (unit: bytes): scenes are a few kB; anything near this is not one.
inline constexpr std::uintmax_t kMaxSceneBytes = 16u << 20;
/// The largest OBJ mesh file read for a rigid body (unit: bytes); tinyobjloader holds it whole.
inline constexpr std::uintmax_t kMaxMeshBytes = 512u << 20;

/// Loads and validates a scene file. `overrides` are "key.path=value" strings from `--set`
/// (e.g. "fluid.particle_spacing=0.01", "fluid.phases[0].viscosity=1e-3") applied before validation.
/// Throws sph::InputError listing every problem found, each with file:line:col (a missing file,
/// unparsable YAML, unknown keys with a did-you-mean suggestion, wrong types, out-of-range or
/// disallowed values, missing required keys, references to undefined phases, bad overrides).
/// Relative paths: output.directory written in the scene is made absolute against the scene file's
/// folder; given with --set, against the working directory; left empty when not given.
SceneSpec loadScene(const std::string& path, const std::vector<std::string>& overrides = {});

/// Same as loadScene but from YAML text; `virtual_path` names it in messages and anchors relative paths.
SceneSpec loadSceneFromString(const std::string& yaml, const std::string& virtual_path,
                              const std::vector<std::string>& overrides = {});

/// The fully resolved scene (every key, defaults filled) as a JSON object, for run.json.
/// Keys in schema order, plus "source_file" first. JSON has no infinity: +-inf are written as the
/// strings "inf" / "-inf" (e.g. an inflow's default stop), NaN as null.
std::string sceneToJson(const SceneSpec& spec);

}  // namespace sph::io
