// Wavefront OBJ files: reading (tinyobjloader) for rigid-body meshes and `compare`, writing for
// the isosurface and body exports. Z is up, units are metres; see README "Blender" for the import
// axes.
#pragma once

#include "core/mesh.h"

#include <string>

namespace sph::io {

/// Reads the triangles of an OBJ file (polygons are fan-triangulated by tinyobjloader); vertex
/// normals are kept when every face has them. Throws InputError naming the file (and the line,
/// when tinyobjloader reports one) when the file is missing, unreadable or has no triangles.
TriMesh readObj(const std::string& path);

/// OBJ text: optional "# comment" lines, `v x y z [r g b]`, `vn`, then `f a//a b//b c//c`
/// (1-based). Numbers use a fixed "%.6g" format so the same mesh gives the same bytes.
std::string objText(const TriMesh& m, const std::string& comment = "");

/// Writes objText() atomically (temporary file, then rename). Throws std::runtime_error on failure.
void writeObj(const std::string& path, const TriMesh& m, const std::string& comment = "");

}  // namespace sph::io
