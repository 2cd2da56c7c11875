// Wavefront OBJ files: reading (tinyobjloader) for rigid-body meshes and `compare`, writing for
// the isosurface and body exports. Z is up, units are metres; see README "Blender" for the import
// axes.
#pragma once

#include "core/mesh.h"

#include <string>

namespace sph::io {

/// Reads the triangles of an OBJ file (polygons are fan-triangulated by tinyobjloader); vertex
/// normals are kept when every face has them. Throws InputError naming the file (and the line
/// for a line that is not OBJ) when the file is missing or unreadable, or has no triangles
/// unless `allow_empty` (an isosurface frame with no fluid of that phase is an empty mesh).
TriMesh readObj(const std::string& path, bool allow_empty = false);

/// OBJ text: optional "# comment" lines, `v x y z [r g b]`, `vn`, then `f a//a b//b c//c`
/// (1-based). Numbers use a fixed "%.6g" format so the same mesh gives the same bytes.
std::string objText(const TriMesh& m, const std::string& comment = "");

/// Writes objText() atomically (temporary file, then rename). Throws std::runtime_error on failure.
void writeObj(const std::string& path, const TriMesh& m, const std::string& comment = "");

}  // namespace sph::io
