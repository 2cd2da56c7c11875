// The only translation unit that includes OpenVDB (its headers are heavy; see toolchain.md).
#include "io/vdb_writer.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetRebuild.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace sph::io {

namespace {

openvdb::math::Transform::Ptr worldTransform(const DenseGrid& g) {
  auto xform = openvdb::math::Transform::createLinearTransform(g.spacing);
  xform->postTranslate(openvdb::Vec3d(g.origin.x(), g.origin.y(), g.origin.z()));
  return xform;
}

void checkGrid(const NamedGrid& ng) {
  const DenseGrid* g = ng.grid;
  if (g == nullptr) throw std::runtime_error("VDB grid '" + ng.name + "' has no data");
  const std::size_t n = static_cast<std::size_t>(g->dims[0]) * static_cast<std::size_t>(g->dims[1]) *
                        static_cast<std::size_t>(g->dims[2]);
  if (g->dims[0] <= 0 || g->dims[1] <= 0 || g->dims[2] <= 0 || g->values.size() != n || !(g->spacing > 0))
    throw std::runtime_error("VDB grid '" + ng.name + "' has inconsistent dimensions or spacing");
}

// Dense samples (x fastest) into a sparse grid; samples below `tolerance` stay inactive background.
openvdb::FloatGrid::Ptr toSparse(const DenseGrid& g, const std::vector<float>& values, float background, float tolerance) {
  const openvdb::CoordBBox bbox(openvdb::Coord(0, 0, 0), openvdb::Coord(g.dims[0] - 1, g.dims[1] - 1, g.dims[2] - 1));
  // Dense<LayoutXYZ> is x-fastest; the wrapped array is only read by copyFromDense.
  openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(bbox, const_cast<float*>(values.data()));
  auto grid = openvdb::FloatGrid::create(background);
  openvdb::tools::copyFromDense(dense, *grid, tolerance);
  grid->setTransform(worldTransform(g));
  return grid;
}

// OpenVDB's io::Archive writes a random UUID into every file's header (the magic number, the file
// and library versions and a flag first: 21 bytes, then 36 characters, 8-4-4-4-12 hex digits), so
// two runs of one scene gave files that differed in those bytes. Replace it with a UUID derived from
// the rest of the file (two 64-bit FNV-1a hashes, RFC 9562's version 8, "custom"): the same grids
// give the same bytes, different ones a different UUID, as readers that cache by UUID expect. A header
// not of that shape (another OpenVDB's layout) is left as written.
void deterministicUuid(const std::string& path) {
  constexpr std::size_t kAt = 21, kLen = 36;
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  if (!f) throw std::runtime_error("cannot reopen " + path);
  char head[kAt + kLen];
  if (!f.read(head, sizeof head)) return;  // shorter than a header: leave it
  for (std::size_t i = 0; i < kLen; ++i) {
    const char c = head[kAt + i];
    const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
    if (dash ? c != '-' : !std::isxdigit(static_cast<unsigned char>(c))) return;
  }
  // The rest of the file, streamed (a frame's file can be large).
  uint64_t hi = 0xcbf29ce484222325ull, lo = 0x84222325cbf29ce4ull;
  std::vector<char> buf(1 << 20);
  while (f) {
    f.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const std::streamsize got = f.gcount();
    for (std::streamsize i = 0; i < got; ++i) {
      const auto b = static_cast<unsigned char>(buf[static_cast<std::size_t>(i)]);
      hi = (hi ^ b) * 0x100000001b3ull;
      lo = (lo ^ b) * 0x100000001b3ull;
    }
  }
  hi = (hi & ~0xf000ull) | 0x8000ull;       // version 8 (the 13th hex digit)
  lo = (lo & ~(3ull << 62)) | (2ull << 62);  // variant 10 (RFC 9562)
  char uuid[kLen + 1];
  std::snprintf(uuid, sizeof uuid, "%08x-%04x-%04x-%04x-%012llx", static_cast<unsigned>(hi >> 32),
                static_cast<unsigned>((hi >> 16) & 0xffff), static_cast<unsigned>(hi & 0xffff),
                static_cast<unsigned>(lo >> 48), static_cast<unsigned long long>(lo & 0xffffffffffffull));
  f.clear();
  f.seekp(static_cast<std::streamoff>(kAt));
  f.write(uuid, static_cast<std::streamsize>(kLen));
  if (!f) throw std::runtime_error("cannot write " + path);
}

void initialiseOnce() {
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
}

openvdb::GridPtrVecPtr readGrids(const std::string& path) {
  initialiseOnce();
  try {
    openvdb::io::File file(path);
    file.open();
    auto grids = file.getGrids();
    file.close();
    return grids;
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read " + path + ": " + e.what());
  }
}

}  // namespace

std::vector<VdbGridInfo> readVdbInfo(const std::string& path) {
  std::vector<VdbGridInfo> info;
  const openvdb::GridPtrVecPtr grids = readGrids(path);  // keep alive: the loop ranges over *grids
  for (const auto& base : *grids) {
    VdbGridInfo i;
    i.name = base->getName();
    i.grid_class = openvdb::GridBase::gridClassToMenuName(base->getGridClass());
    i.value_type = base->valueType();
    i.voxel_size = base->voxelSize()[0];
    const openvdb::Vec3d o = base->indexToWorld(openvdb::Vec3d(0, 0, 0));
    i.index_origin_world = Eigen::Vector3d(o[0], o[1], o[2]);
    i.active_voxels = base->activeVoxelCount();
    if (auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) {
      bool first = true;
      for (auto it = fg->cbeginValueOn(); it; ++it) {
        const float v = *it;
        if (first || v < i.min_active) i.min_active = v;
        if (first || v > i.max_active) i.max_active = v;
        first = false;
      }
    }
    info.push_back(i);
  }
  return info;
}

float sampleVdb(const std::string& path, const std::string& name, const Eigen::Vector3d& world) {
  const openvdb::GridPtrVecPtr grids = readGrids(path);
  for (const auto& base : *grids) {
    if (base->getName() != name) continue;
    auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!fg) throw std::runtime_error(path + ": grid '" + name + "' is not a float grid");
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(*fg);
    return sampler.wsSample(openvdb::Vec3d(world.x(), world.y(), world.z()));
  }
  throw std::runtime_error(path + ": no grid named '" + name + "'");
}

void writeVdb(const std::string& path, const std::vector<NamedGrid>& grids, const VdbOptions& options) {
  initialiseOnce();
  openvdb::GridPtrVec out;
  const DenseGrid* density = nullptr;
  for (const NamedGrid& ng : grids) {
    checkGrid(ng);
    const DenseGrid& g = *ng.grid;
    const float vmax = g.values.empty() ? 0.f : *std::max_element(g.values.begin(), g.values.end());
    auto grid = toSparse(g, g.values, 0.f, 1e-6f * std::max(vmax, 0.f));
    grid->setName(ng.name);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("creator", openvdb::StringMetadata("sphaptics " SPHAPTICS_VERSION));
    out.push_back(grid);
    if (ng.name == "density") density = &g;
  }
  if (options.level_set) {
    if (density == nullptr) throw std::runtime_error("VDB level set requested but no grid is named 'density'");
    // levelSetRebuild treats values below the iso value as inside; the density field is larger
    // inside, so rebuild from (iso - density) at 0. Every sample is kept active for the rebuild.
    std::vector<float> flipped(density->values.size());
    for (std::size_t i = 0; i < flipped.size(); ++i) flipped[i] = options.iso - density->values[i];
    auto signed_field = toSparse(*density, flipped, options.iso, 0.f);
    auto surface = openvdb::tools::levelSetRebuild(*signed_field, 0.f, options.half_width);
    surface->setName("surface");
    surface->setGridClass(openvdb::GRID_LEVEL_SET);
    out.push_back(surface);
  }

  const std::string tmp = path + ".tmp";
  try {
    openvdb::io::File file(tmp);
    file.write(out);
    file.close();
    deterministicUuid(tmp);
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " + ec.message());
}

}  // namespace sph::io
