#include "core/isosurface.h"

#include "core/errors.h"
#include "core/marching_cubes_table.h"

#include <algorithm>
#include <cmath>

namespace sph {

static_assert(sizeof(IsoParams) == 64, "IsoParams layout must match the device");
static_assert(MarchingCubesTable::kMaxTriangles == MC_MAX_TRIANGLES, "table width must match the device");

namespace {
constexpr std::size_t kLocal = 64;       // work-group size of the per-node and per-cell kernels
constexpr uint32_t kBoundGroups = 64;    // chunks of the bounding-box reduction
constexpr double kMaxNodes = 1 << 25;    // grid nodes per extraction (~0.7 GB of device memory)
}  // namespace

SurfaceMesher::SurfaceMesher(ClContext& cl, KernelSet& kernels) : cl_(cl), kernels_(kernels), scan_(cl, kernels) {
  // The case table, flattened: 256 triangle counts and 256 x (3 * MC_MAX_TRIANGLES) edge indices.
  const MarchingCubesTable& t = marchingCubesTable();
  std::vector<uint8_t> edges;
  for (const auto& row : t.triangles) edges.insert(edges.end(), row.begin(), row.end());
  clCall("uploading the marching-cubes table", [&] {
    case_triangles_ = cl::Buffer(cl_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, std::size_t(256),
                                 const_cast<uint8_t*>(t.triangle_count.data()));
    case_edges_ = cl::Buffer(cl_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, edges.size(), edges.data());
    return 0;
  });
}

std::size_t SurfaceMesher::bytes() const {
  std::size_t b = scan_.bytes() + 256 * (1 + 3 * MC_MAX_TRIANGLES);
  for (const Grow* g : {&bounds_, &field_, &edge_mask_, &vert_count_, &vert_offset_, &tri_count_, &tri_offset_,
                        &vert_pos_, &vert_normal_, &vert_colour_, &tris_})
    b += g->bytes;
  return b;
}

cl::Buffer& SurfaceMesher::ensure(Grow& g, std::size_t bytes) {
  bytes = std::max<std::size_t>(bytes, 16);
  if (bytes > g.bytes) {
    const std::size_t grown = std::max(bytes, g.bytes + g.bytes / 4);  // amortise growth over frames
    g.buf = clCall("allocating an isosurface buffer",
                   [&] { return cl::Buffer(cl_.context(), CL_MEM_READ_WRITE, grown); });
    g.bytes = grown;
  }
  return g.buf;
}

std::vector<TriMesh> SurfaceMesher::meshParticles(const ParticleView& in, const IsoSettings& s) {
  SPH_ASSERT(s.spacing > 0, "isosurface spacing must be positive");
  SPH_ASSERT(in.num_phases >= 1 && in.num_phases <= SPH_MAX_PHASES, "phase count out of range");
  std::vector<TriMesh> meshes(in.num_phases);
  if (in.count == 0) return meshes;
  const SimParams& p = *in.params;
  auto& q = cl_.queue();

  // 1. Bounding box of the fluid (chunked reduction on the device, the last step on the host).
  const uint32_t chunk = static_cast<uint32_t>((in.count + kBoundGroups - 1) / kBoundGroups);
  cl::Buffer& bounds = ensure(bounds_, kBoundGroups * 6 * 4);
  std::vector<float> part(kBoundGroups * 6);
  {
    SimParams pp = p;
    pp.n_fluid = static_cast<sph_uint>(in.count);
    kernels_.call("iso_bounds", kBoundGroups, 0, pp, chunk, *in.pos, bounds);
    clCall("reading the fluid bounds", [&] { return q.enqueueReadBuffer(bounds, CL_TRUE, 0, part.size() * 4, part.data()); });
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = Eigen::Vector3d::Constant(-INFINITY);
  for (uint32_t g = 0; g < kBoundGroups; ++g)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], static_cast<double>(part[6 * g + static_cast<uint32_t>(a)]));
      hi[a] = std::max(hi[a], static_cast<double>(part[6 * g + 3 + static_cast<uint32_t>(a)]));
    }
  if (!(lo.array() <= hi.array()).all()) return meshes;  // no finite particle

  // 2. The surface grid: nodes at grid_origin + spacing * (n + 1/2) (offset half a node from the
  //    neighbour grid's corner), covering the box grown by H plus one node on each side, so that the
  //    border nodes are farther than H from every particle: the field there is 0 and every surface
  //    is closed. The box is clipped to the neighbour grid (particles outside it are clamped there).
  double spacing = s.spacing;
  IsoParams ip{};
  std::array<long, 3> first{}, dims{};
  for (;;) {
    double nodes = 1;
    for (int a = 0; a < 3; ++a) {
      const double g0 = p.grid_origin[a], g1 = g0 + p.grid_dims[a] * static_cast<double>(p.cell_size);
      const double o = g0 + 0.5 * spacing;
      const double l = std::clamp(lo[a], g0, g1) - p.support, h = std::clamp(hi[a], g0, g1) + p.support;
      first[static_cast<std::size_t>(a)] = static_cast<long>(std::floor((l - o) / spacing)) - 1;
      const long last = static_cast<long>(std::ceil((h - o) / spacing)) + 1;
      dims[static_cast<std::size_t>(a)] = last - first[static_cast<std::size_t>(a)] + 1;
      nodes *= static_cast<double>(dims[static_cast<std::size_t>(a)]);
    }
    if (nodes <= kMaxNodes) break;
    spacing *= 2;  // a fluid spread over a huge box: coarsen rather than run out of memory
  }
  for (int a = 0; a < 3; ++a) {
    ip.origin[a] = static_cast<float>(p.grid_origin[a] + spacing * (static_cast<double>(first[static_cast<std::size_t>(a)]) + 0.5));
    ip.dims[a] = static_cast<int>(dims[static_cast<std::size_t>(a)]);
    last_grid_.origin[a] = ip.origin[a];
    last_grid_.dims[static_cast<std::size_t>(a)] = ip.dims[a];
  }
  last_grid_.spacing = spacing;
  ip.spacing = static_cast<float>(spacing);
  ip.iso = s.iso;
  ip.num_nodes = static_cast<sph_uint>(dims[0] * dims[1] * dims[2]);
  ip.num_fields = in.num_phases;
  last_fields_ = in.num_phases;
  ip.with_colour = s.vertex_colours ? 1u : 0u;
  ip.reach = static_cast<float>(p.support + in.drift);

  // 3. The field of every phase in one gather over the neighbour grid.
  {
    cl::Buffer& field = ensure(field_, std::size_t(ip.num_nodes) * in.num_phases * 4);
    kernels_.call("iso_field", ip.num_nodes, kLocal, p, ip, *in.pos, *in.phase, *in.cell_start, field);
  }

  // 4. Marching cubes, phase by phase (unless only the field is wanted: empty meshes then).
  for (uint32_t f = 0; f < in.num_phases && s.meshes; ++f) {
    ip.field = f;
    meshes[f] = march(ip, &in);
  }
  return meshes;
}

TriMesh SurfaceMesher::meshGrid(const DenseGrid& grid, float iso) {
  SPH_ASSERT(grid.dims[0] >= 2 && grid.dims[1] >= 2 && grid.dims[2] >= 2, "a grid needs 2 nodes per axis");
  SPH_ASSERT(grid.values.size() == static_cast<std::size_t>(grid.dims[0]) * grid.dims[1] * grid.dims[2],
             "grid values do not match its dimensions");
  IsoParams ip{};
  for (int a = 0; a < 3; ++a) {
    ip.origin[a] = static_cast<float>(grid.origin[a]);
    ip.dims[a] = grid.dims[static_cast<std::size_t>(a)];
  }
  ip.spacing = static_cast<float>(grid.spacing);
  ip.iso = iso;
  ip.num_nodes = static_cast<sph_uint>(grid.values.size());
  ip.num_fields = 1;
  last_fields_ = 1;
  cl::Buffer& field = ensure(field_, grid.values.size() * 4);
  clCall("uploading a surface field",
         [&] { return cl_.queue().enqueueWriteBuffer(field, CL_TRUE, 0, grid.values.size() * 4, grid.values.data()); });
  last_grid_.origin = grid.origin;
  last_grid_.spacing = grid.spacing;
  last_grid_.dims = grid.dims;
  return march(ip, nullptr);
}

DenseGrid SurfaceMesher::readField(uint32_t phase) {
  DenseGrid g;
  g.origin = last_grid_.origin;
  g.spacing = last_grid_.spacing;
  g.dims = last_grid_.dims;
  const std::size_t n = static_cast<std::size_t>(g.dims[0]) * g.dims[1] * g.dims[2];
  if (phase >= last_fields_ || n == 0) return g;
  g.values.resize(n);
  clCall("reading the surface field",
         [&] { return cl_.queue().enqueueReadBuffer(field_.buf, CL_TRUE, phase * n * 4, n * 4, g.values.data()); });
  return g;
}

TriMesh SurfaceMesher::march(IsoParams ip, const ParticleView* particles) {
  auto& q = cl_.queue();
  const uint32_t nodes = ip.num_nodes;
  const uint32_t cells = static_cast<uint32_t>((ip.dims[0] - 1) * (ip.dims[1] - 1) * (ip.dims[2] - 1));
  cl::Buffer& field = field_.buf;
  cl::Buffer& mask = ensure(edge_mask_, std::size_t(nodes) * 4);
  cl::Buffer& vcount = ensure(vert_count_, std::size_t(nodes) * 4);
  cl::Buffer& voff = ensure(vert_offset_, (std::size_t(nodes) + 1) * 4);
  cl::Buffer& tcount = ensure(tri_count_, std::size_t(cells) * 4);
  cl::Buffer& toff = ensure(tri_offset_, (std::size_t(cells) + 1) * 4);

  // Classify: crossing edges per node, triangles per cell; prefix sums give the output slots.
  kernels_.call("mc_node_edges", nodes, kLocal, ip, field, mask, vcount);
  kernels_.call("mc_cell_count", cells, kLocal, ip, field, case_triangles_, tcount);
  scan_.run(vcount, voff, nodes);
  scan_.run(tcount, toff, cells);
  uint32_t nv = 0, nt = 0;
  clCall("reading the isosurface size", [&] {
    q.enqueueReadBuffer(voff, CL_FALSE, std::size_t(nodes) * 4, 4, &nv);
    q.enqueueReadBuffer(toff, CL_TRUE, std::size_t(cells) * 4, 4, &nt);
    return 0;
  });
  TriMesh mesh;
  if (nv == 0 || nt == 0) return mesh;

  // Emit the welded vertices, then the triangles that index them.
  const bool colours = particles && ip.with_colour;
  cl::Buffer& vpos = ensure(vert_pos_, std::size_t(nv) * 16);
  cl::Buffer& vnrm = ensure(vert_normal_, std::size_t(nv) * 16);
  cl::Buffer& vcol = ensure(vert_colour_, colours ? std::size_t(nv) * 16 : 16);
  cl::Buffer& tris = ensure(tris_, std::size_t(nt) * 12);
  SimParams none{};
  cl::Kernel& kv = kernels_["mc_emit_vertices"];
  kv.setArg(0, sizeof(SimParams), particles ? particles->params : &none);
  kv.setArg(1, sizeof(IsoParams), &ip);
  kv.setArg(2, field);
  kv.setArg(3, mask);
  kv.setArg(4, voff);
  // Without particles the colour pass is off and these arguments are never read.
  kv.setArg(5, particles ? *particles->pos : vpos);
  kv.setArg(6, particles ? *particles->phase : vpos);
  kv.setArg(7, particles ? *particles->colour : vpos);
  kv.setArg(8, particles ? *particles->cell_start : vpos);
  kv.setArg(9, vpos);
  kv.setArg(10, vnrm);
  kv.setArg(11, vcol);
  kernels_.enqueue("mc_emit_vertices", nodes, kLocal);
  kernels_.call("mc_emit_triangles", cells, kLocal, ip, field, case_triangles_, case_edges_, mask, voff, toff, tris);

  // Read back into a TriMesh.
  std::vector<Eigen::Vector4f> pos(nv), nrm(nv), col(colours ? nv : 0);
  mesh.triangles.resize(nt);
  clCall("reading the isosurface", [&] {
    q.enqueueReadBuffer(vpos, CL_FALSE, 0, std::size_t(nv) * 16, pos.data());
    q.enqueueReadBuffer(vnrm, CL_FALSE, 0, std::size_t(nv) * 16, nrm.data());
    if (colours) q.enqueueReadBuffer(vcol, CL_FALSE, 0, std::size_t(nv) * 16, col.data());
    q.enqueueReadBuffer(tris, CL_FALSE, 0, std::size_t(nt) * 12, mesh.triangles.data());
    q.finish();
    return 0;
  });
  mesh.positions.resize(nv);
  mesh.normals.resize(nv);
  for (uint32_t i = 0; i < nv; ++i) {
    mesh.positions[i] = pos[i].head<3>();
    mesh.normals[i] = nrm[i].head<3>();
  }
  if (colours) {
    mesh.colours.resize(nv);
    for (uint32_t i = 0; i < nv; ++i) mesh.colours[i] = col[i].head<3>();
  }
  return mesh;
}

}  // namespace sph
