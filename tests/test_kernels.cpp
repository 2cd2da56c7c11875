// The first two test layers of DESIGN.md section 7:
//   1. kernel math (host functions of kernels/shared/sph_kernel.h, both kernels);
//   2. every OpenCL kernel of kernels/*.cl against a plain, brute-force C++ reference, on the
//      default device (pocl on the CPU here), with a stated tolerance.
//
// Tolerances. The device and the references evaluate the same float formulas (the reference uses
// the very same sph_w / sph_grad_factor host functions), but they differ in
//   - summation order (neighbour-list / grid order on the device, index order in the reference)
//     and precision (float accumulation on the device, double in the reference): the error of a
//     float sum of n terms is at most ~n * eps * sum|terms| (eps = 6e-8), and for the <= 200 terms
//     of these scenes that is <= 1.2e-5 * sum|terms|, typically sqrt(n) * eps ~ 1e-6;
//   - contraction of a*b+c into FMA (pocl does it, the host does not) and OpenCL's few-ulp
//     sqrt / cbrt / division: a few ulp per term.
// So every per-particle comparison is made relative to the sum of the magnitudes of the terms
// that make up the value (its "scale"), not to the value itself, which may be the small remainder
// of large cancelling terms (pressure forces in the bulk, p = B (ratio^7 - 1) near rest).
// Pairs at |r^2 - H^2| <= 1e-5 H^2 may land on either side of the support test; both kernels go
// to zero with zero slope at r = H, so they add nothing measurable to sums. Likewise the
// neighbour-list comparison ignores pairs at |r^2 - R^2| <= 1e-5 R^2 (R = list radius).
//
// The kernels are bound and launched as core/simulation.cpp does it (same arguments, work-group
// size 64, so the guards against work-items past n_fluid are exercised too), but each stage is run
// on its own with inputs downloaded from the previous one, so that a failure names one kernel.
#include "core/cl_context.h"
#include "core/model.h"
#include "kernels/shared/sim_params.h"
#include "kernels/shared/sph_kernel.h"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

using sph::ClContext;
using sph::KernelSet;

constexpr std::size_t kLocal = 64;  // work-group size of the per-particle kernels, as in simulation.cpp

struct F4 {
  float x = 0, y = 0, z = 0, w = 0;
};
static_assert(sizeof(F4) == 16, "F4 must match cl_float4");

float uni(std::mt19937& g, float a, float b) {  // portable: mt19937 is fully specified
  return a + (b - a) * static_cast<float>(g() >> 8) * (1.0f / 16777216.0f);
}

double norm3(double x, double y, double z) { return std::sqrt(x * x + y * y + z * z); }

// =============================================================================================
// 1. Kernel math
// =============================================================================================

const int kKinds[] = {SPH_KERNEL_CUBIC_SPLINE, SPH_KERNEL_WENDLAND_C2};
const char* kindName(int k) { return k == SPH_KERNEL_WENDLAND_C2 ? "Wendland C2" : "cubic spline"; }

TEST_CASE("kernel math: W >= 0, compact support, unit integral", "[kernels]") {
  for (int kind : kKinds) {
    for (float H : {1.0f, 0.04f}) {
      INFO(kindName(kind) << ", H = " << H);
      // W >= 0 everywhere, W = 0 and grad W = 0 from r = H on.
      int negative = 0, outside_nonzero = 0;
      for (int k = 0; k <= 3000; ++k) {
        const float r = 2.0f * H * static_cast<float>(k) / 3000.0f;
        const float w = sph_w(kind, r, H);
        if (!(w >= 0.0f)) ++negative;
        if (r >= H && (w != 0.0f || sph_grad_factor(kind, r, H) != 0.0f)) ++outside_nonzero;
      }
      CHECK(negative == 0);
      CHECK(outside_nonzero == 0);
      CHECK(sph_w(kind, H, H) == 0.0f);
      CHECK(sph_w(kind, 0.0f, H) > 0.0f);
      CHECK(std::isfinite(sph_grad_factor(kind, 0.0f, H)));

      // 4 pi int_0^H W(r) r^2 dr = 1 (composite Simpson, 20000 intervals: its error is ~1e-12;
      // W is evaluated in float, ~1e-7 relative, so 1e-5 is a safe bound, tighter than needed).
      const int n = 20000;
      const double step = static_cast<double>(H) / n;
      double integral = 0.0;
      for (int k = 0; k <= n; ++k) {
        const double r = k * step;
        const double f = sph_w(kind, static_cast<float>(r), H) * r * r;
        integral += f * (k == 0 || k == n ? 1.0 : (k % 2 ? 4.0 : 2.0));
      }
      integral *= 4.0 * M_PI * step / 3.0;
      INFO("integral = " << integral);
      CHECK(std::abs(integral - 1.0) < 1e-5);
    }
  }
}

TEST_CASE("kernel math: grad factor is dW/dr / r, gradient antisymmetric", "[kernels]") {
  for (int kind : kKinds) {
    const float H = 0.04f;
    for (float q : {0.05f, 0.1f, 0.25f, 0.4f, 0.49f, 0.51f, 0.6f, 0.75f, 0.9f, 0.97f}) {
      INFO(kindName(kind) << ", q = " << q);
      const float r = q * H;
      // Central difference with step e = 0.01 min(r, H - r): its truncation error is ~(e / l)^2
      // ~ 1e-4 relative, l = min(r, H - r) the length over which W changes (W ~ (1 - q)^3 or ^4
      // near the support; W is C2 across the cubic spline's joint at q = 1/2); the float rounding
      // of W gives eps W / (e |dW/dr|) <= ~2e-4 (at small q, where dW/dr -> 0). 1e-3 relative.
      const float e = 0.01f * std::min(r, H - r);
      const double fd = (static_cast<double>(sph_w(kind, r + e, H)) - sph_w(kind, r - e, H)) /
                        (2.0 * static_cast<double>(e)) / static_cast<double>(r);
      const double F = sph_grad_factor(kind, r, H);
      INFO("finite difference " << fd << ", grad factor " << F);
      CHECK(F < 0.0);  // W decreases monotonically
      CHECK(std::abs(fd - F) <= 1e-3 * std::abs(F));
    }
    // grad W(-x) = -grad W(x), and grad W points towards the centre (W decreases outwards).
    std::mt19937 g(7);
    int bad = 0;
    for (int k = 0; k < 1000; ++k) {
      const float x = uni(g, -H, H), y = uni(g, -H, H), z = uni(g, -H, H);
      const float r = std::sqrt(x * x + y * y + z * z), rm = std::sqrt((-x) * (-x) + (-y) * (-y) + (-z) * (-z));
      const float F = sph_grad_factor(kind, r, H), Fm = sph_grad_factor(kind, rm, H);
      if (F * x != -(Fm * -x) || F * y != -(Fm * -y) || F * z != -(Fm * -z) || F > 0.0f) ++bad;
    }
    CHECK(bad == 0);
  }
  // The cubic spline's two branches meet at q = 1/2 (value and slope).
  const float H = 1.0f;
  CHECK(sph_cubic_w(0.5f, H) == Approx(sph_cubic_w(0.5f + 1e-6f, H)).epsilon(1e-5));
  CHECK(sph_cubic_grad_factor(0.5f, H) == Approx(sph_cubic_grad_factor(0.5f + 1e-6f, H)).epsilon(1e-4));
}

/// sum_j W(x0 - x_j) V and sum_j grad W(x0 - x_j) V over a cubic lattice of spacing dx (x0 a lattice point).
void latticeSums(int kind, float dx, float H, double& sumW, double grad[3]) {
  const int m = static_cast<int>(std::ceil(H / dx)) + 1;
  const double V = static_cast<double>(dx) * dx * dx;
  sumW = 0.0;
  grad[0] = grad[1] = grad[2] = 0.0;
  for (int k = -m; k <= m; ++k)
    for (int j = -m; j <= m; ++j)
      for (int i = -m; i <= m; ++i) {
        const float x = -static_cast<float>(i) * dx, y = -static_cast<float>(j) * dx, z = -static_cast<float>(k) * dx;
        const float r = std::sqrt(x * x + y * y + z * z);
        sumW += sph_w(kind, r, H) * V;
        const double F = sph_grad_factor(kind, r, H);
        grad[0] += F * x * V;
        grad[1] += F * y * V;
        grad[2] += F * z * V;
      }
}

TEST_CASE("kernel math: lattice sums (partition of unity, zero gradient sum)", "[kernels]") {
  const float dx = 0.02f;
  struct Case {
    int kind;
    float ratio;
    bool unity_within_1pct;
  };
  // The cubic spline at H = 2 dx and Wendland C2 at H = 3 dx sum to 1 within 1 %; Wendland C2 at
  // H = 2 dx is too few neighbours for it (sum ~1.034), so only its gradient sum is checked.
  for (const Case c : {Case{SPH_KERNEL_CUBIC_SPLINE, 2.0f, true}, Case{SPH_KERNEL_WENDLAND_C2, 3.0f, true},
                       Case{SPH_KERNEL_WENDLAND_C2, 2.0f, false}, Case{SPH_KERNEL_CUBIC_SPLINE, 3.0f, true}}) {
    const float H = c.ratio * dx;
    double sumW, grad[3];
    latticeSums(c.kind, dx, H, sumW, grad);
    INFO(kindName(c.kind) << ", H = " << c.ratio << " dx: sum W V = " << sumW << ", sum grad W V = (" << grad[0]
                          << ", " << grad[1] << ", " << grad[2] << ")");
    if (c.unity_within_1pct) CHECK(std::abs(sumW - 1.0) < 0.01);
    CHECK(std::abs(sumW - 1.0) < 0.05);
    // Exactly zero by symmetry up to rounding; the scale of one term is ~1/H.
    CHECK(norm3(grad[0], grad[1], grad[2]) * H < 1e-5);
  }
}

// =============================================================================================
// 2. OpenCL kernels against brute-force references
// =============================================================================================

ClContext& clctx() {
  static ClContext cl("");
  return cl;
}

std::string programOptions(int kind, bool laminar) {
  return "-cl-std=CL1.2 -DSPH_KERNEL=" + std::to_string(kind) + " -DSPH_LAMINAR=" + (laminar ? "1" : "0");
}

/// One KernelSet per build-option string, built once per test run (`extra`: more options).
KernelSet& kernelSet(int kind, bool laminar, const std::string& extra = "") {
  static std::map<std::string, std::unique_ptr<KernelSet>> cache;
  const std::string options = programOptions(kind, laminar) + extra;
  auto& ks = cache[options];
  if (!ks) ks = std::make_unique<KernelSet>(clctx(), options);
  return *ks;
}

template <class T>
cl::Buffer toDevice(std::vector<T> v, std::size_t min_count = 1) {
  if (v.size() < std::max<std::size_t>(min_count, 1)) v.resize(std::max<std::size_t>(min_count, 1));
  return cl::Buffer(clctx().context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, v.size() * sizeof(T), v.data());
}

template <class T>
cl::Buffer zeros(std::size_t count) {
  return toDevice(std::vector<T>(std::max<std::size_t>(count, 1)));
}

template <class T>
std::vector<T> fromDevice(const cl::Buffer& b, std::size_t count) {
  std::vector<T> v(count);
  if (count > 0) clctx().queue().enqueueReadBuffer(b, CL_TRUE, 0, count * sizeof(T), v.data());
  return v;
}

template <class T>
void write(const cl::Buffer& b, const std::vector<T>& v) {
  if (!v.empty()) clctx().queue().enqueueWriteBuffer(b, CL_TRUE, 0, v.size() * sizeof(T), v.data());
}

/// The cell of x exactly as sph_cell_of() computes it on the device (float, round down, clamp).
int cellCoord(const SimParams& P, float x, int a) {
  const int c = static_cast<int>(std::floor((x - P.grid_origin[a]) / P.cell_size));
  return std::min(std::max(c, 0), P.grid_dims[a] - 1);
}
uint32_t cellIndex(const SimParams& P, const F4& x) {
  return static_cast<uint32_t>(cellCoord(P, x.x, 0) +
                               P.grid_dims[0] * (cellCoord(P, x.y, 1) + P.grid_dims[1] * cellCoord(P, x.z, 2)));
}
/// Whether x lies so close to a cell face that host and device may round it to different cells.
bool nearCellFace(const SimParams& P, const F4& x) {
  const float v[3] = {x.x, x.y, x.z};
  for (int a = 0; a < 3; ++a) {
    const double t = (static_cast<double>(v[a]) - P.grid_origin[a]) / P.cell_size;
    if (std::abs(t - std::round(t)) < 1e-5) return true;
  }
  return false;
}

/// Squared distance in float, as the device computes it (up to FMA contraction).
float dist2(const F4& a, const F4& b, float& dx, float& dy, float& dz) {
  dx = a.x - b.x;
  dy = a.y - b.y;
  dz = a.z - b.z;
  return dx * dx + dy * dy + dz * dz;
}

/// A small scene like compile() makes: a jittered lattice block of two phases in a box whose
/// x_min and z_min walls are closed (2 layers of boundary particles with Akinci volumes), the
/// free surface inside the box, plus a few special particles: exactly on a cell face, a pair at
/// the same position, and pairs outside the grid (clamped into its border cells).
struct Scene {
  SimParams P{};
  float dx = 0.02f;
  std::vector<F4> pos, vel, colour;
  std::vector<uint32_t> phase, id;
  std::vector<F4> bpos;
  std::vector<uint32_t> bcell_start;
};

/// `skin`: the Verlet-list skin as a fraction of H (compile() uses 0.25): cells and neighbour
/// lists reach H (1 + skin).
Scene makeScene(int kind, float ratio, bool boundary, uint32_t eos, bool clamp, uint32_t seed, float skin = 0.25f) {
  Scene s;
  const float dx = s.dx;
  const float H = ratio * dx;
  const float R = H + skin * H;  // list radius = cell size
  SimParams& P = s.P;
  const int layers = 2;
  const float L[3] = {12 * dx, 10 * dx, 10 * dx};
  const float margin = (layers + 1) * dx;
  for (int a = 0; a < 3; ++a) {
    P.domain_min[a] = 0.0f;
    P.domain_max[a] = L[a];
    P.grid_origin[a] = -margin;
    P.grid_dims[a] = std::max(1, static_cast<int>(std::ceil((L[a] + 2 * margin) / R)));
  }
  P.cell_size = R;
  P.support = H;
  P.h = 0.5f * H;
  P.rest_volume = dx * dx * dx;
  P.closed_mask = (1u << 0) | (1u << 4);  // x_min and z_min
  P.kernel_type = static_cast<sph_uint>(kind);
  P.eos = eos;
  P.clamp_negative_pressure = clamp ? 1u : 0u;
  P.num_cells = static_cast<sph_uint>(P.grid_dims[0] * P.grid_dims[1] * P.grid_dims[2]);
  // neighbour slots as Simulation sizes them: 1.5x the bulk count within R plus 8, rounded up to 8
  const double rr = R / dx;
  P.max_neighbours = static_cast<sph_uint>((1.5 * 4.18879 * rr * rr * rr + 8.0 + 7.0) / 8.0) * 8u;
  P.dt = 5e-4f;
  P.gravity[0] = 0.0f;
  P.gravity[1] = 0.0f;
  P.gravity[2] = -9.81f;
  P.c0 = 10.0f;
  P.alpha = 0.1f;
  P.colour_diffusion = 1e-3f;
  const float rho0[2] = {1000.0f, 700.0f}, nu[2] = {1e-3f, 1e-2f};
  for (int k = 0; k < 2; ++k) {
    P.phase_rest_density[k] = rho0[k];
    P.phase_mass[k] = rho0[k] * dx * dx * dx;
    P.phase_viscosity[k] = nu[k];
  }

  std::mt19937 g(seed);
  auto add = [&](float x, float y, float z) {
    s.pos.push_back({x, y, z, 0.0f});
    s.vel.push_back({uni(g, -1, 1), uni(g, -1, 1), uni(g, -1, 1), 0.0f});
    s.colour.push_back({uni(g, 0, 1), uni(g, 0, 1), uni(g, 0, 1), 1.0f});
    s.phase.push_back(uni(g, 0, 1) < 0.25f ? 1u : 0u);
    s.id.push_back(1000u + static_cast<uint32_t>(s.id.size()));
  };
  for (int k = 0; k < 7; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 12; ++i) {
        const float jx = uni(g, -0.3f, 0.3f), jy = uni(g, -0.3f, 0.3f), jz = uni(g, -0.3f, 0.3f);
        add((i + 0.5f + jx) * dx, (j + 0.5f + jy) * dx, (k + 0.5f + jz) * dx);
      }
  const float grid_end = P.grid_origin[0] + P.grid_dims[0] * R;
  add(P.grid_origin[0] + 4 * R, 5.1f * dx, 3.3f * dx);  // on a cell face
  add(6.3f * dx, 4.4f * dx, 7.5f * dx);                 // two particles at one position
  add(6.3f * dx, 4.4f * dx, 7.5f * dx);
  add(grid_end + 5 * R, 5.0f * dx, 5.0f * dx);  // far beyond the grid (escaped through the open x_max
  add(grid_end + 5 * R + 0.5f * dx, 5.2f * dx, 5.1f * dx);  // wall): both clamped into the last cells
  add(grid_end + 0.4f * dx, 3.2f * dx, 4.1f * dx);  // just beyond the grid, neighbour of
  add(grid_end - 0.5f * dx, 3.0f * dx, 4.0f * dx);  // one just inside
  // Shuffle, so that the input is far from cell order.
  for (std::size_t i = s.pos.size() - 1; i > 0; --i) {
    const std::size_t j = g() % (i + 1);
    std::swap(s.pos[i], s.pos[j]);
    std::swap(s.vel[i], s.vel[j]);
    std::swap(s.colour[i], s.colour[j]);
    std::swap(s.phase[i], s.phase[j]);
    std::swap(s.id[i], s.id[j]);
  }
  P.n_fluid = static_cast<sph_uint>(s.pos.size());

  // Boundary particles: lattice points outside the box whose every crossed wall is closed.
  s.bcell_start.assign(P.num_cells + 1, 0u);
  if (boundary) {
    auto axis = [&](float lo, float hi) {
      std::vector<float> v;
      for (int k = layers - 1; k >= 0; --k) v.push_back(lo - (k + 0.5f) * dx);
      for (int k = 0; (k + 0.5f) * dx < hi; ++k) v.push_back(lo + (k + 0.5f) * dx);
      for (int k = 0; k < layers; ++k) v.push_back(hi + (k + 0.5f) * dx);
      return v;
    };
    const auto xs = axis(0, L[0]), ys = axis(0, L[1]), zs = axis(0, L[2]);
    std::vector<Eigen::Vector3f> pts;
    for (float z : zs)
      for (float y : ys)
        for (float x : xs) {
          const float p[3] = {x, y, z};
          bool outside = false, allowed = true;
          for (int a = 0; a < 3; ++a) {
            if (p[a] < 0) outside = true, allowed = allowed && ((P.closed_mask >> (2 * a)) & 1u);
            if (p[a] > L[a]) outside = true, allowed = allowed && ((P.closed_mask >> (2 * a + 1)) & 1u);
          }
          if (outside && allowed) pts.emplace_back(x, y, z);
        }
    const std::vector<float> vol = sph::akinciVolumes(pts, H, kind);
    std::vector<std::pair<uint32_t, uint32_t>> keyed;
    for (uint32_t b = 0; b < pts.size(); ++b)
      keyed.emplace_back(cellIndex(P, {pts[b].x(), pts[b].y(), pts[b].z(), 0.0f}), b);
    std::stable_sort(keyed.begin(), keyed.end(), [](auto& a, auto& b) { return a.first < b.first; });
    std::vector<uint32_t> count(P.num_cells, 0u);
    for (auto& [c, b] : keyed) {
      s.bpos.push_back({pts[b].x(), pts[b].y(), pts[b].z(), vol[b] / P.rest_volume});
      ++count[c];
    }
    for (std::size_t c = 0; c < P.num_cells; ++c) s.bcell_start[c + 1] = s.bcell_start[c] + count[c];
  }
  P.n_boundary = static_cast<sph_uint>(s.bpos.size());
  return s;
}

/// Device buffers of one scene and the kernel launches, bound as core/simulation.cpp binds them.
struct Device {
  KernelSet& ks;
  SimParams P;
  std::size_t n;
  uint32_t scan_chunks;
  int cur = 0;
  cl::Buffer pos[2], vel[2], colour[2], phase[2], id[2];
  cl::Buffer cell, rank, sorted, cell_count, cell_start, scan_sums, bpos, bcell_start;
  cl::Buffer density, pressure, pterm, nbr, nbr_count, bnbr, bnbr_count, overflow, acc, crossings, max_speed;
  cl::Buffer snbr, snbr_count, sbnbr, sbnbr_count;  // this step's neighbours within H (density pass)
  cl::Buffer narrow_fail;  // set by the list build when a narrow list's offsets do not fit
  float list_radius = 0;  // build_neighbour_lists' radius (unit: m); 0: the cell size (Verlet lists)
  // Boundary velocities (random, as if every boundary particle were on a moving body), wall
  // pressures and the density pass's marks.
  std::vector<F4> bvel_host;
  cl::Buffer bvel, bpressure, bmark;
  uint32_t nb = 0, stamp = 0;

  /// `scan_chunk_cells`: cells per scan chunk (the simulation uses ~1024; smaller gives several chunks).
  Device(KernelSet& k, const Scene& s, uint32_t scan_chunk_cells = 1024) : ks(k), P(s.P), n(s.pos.size()) {
    const std::size_t cells = P.num_cells;
    for (int b = 0; b < 2; ++b) {
      pos[b] = toDevice(s.pos);
      vel[b] = toDevice(s.vel);
      colour[b] = toDevice(s.colour);
      phase[b] = toDevice(s.phase);
      id[b] = toDevice(s.id);
    }
    cell = zeros<uint32_t>(n);
    rank = zeros<uint32_t>(n);
    sorted = zeros<uint32_t>(n);
    cell_count = toDevice(std::vector<uint32_t>(cells, 0xdeadbeefu));  // grid build must clear it
    cell_start = zeros<uint32_t>(cells + 1);
    scan_chunks = static_cast<uint32_t>(std::max<std::size_t>(1, (cells + scan_chunk_cells - 1) / scan_chunk_cells));
    scan_sums = zeros<uint32_t>(scan_chunks + 1);
    bpos = toDevice(s.bpos);
    bcell_start = toDevice(s.bcell_start);
    nb = static_cast<uint32_t>(s.bpos.size());
    std::mt19937 g(77);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    for (uint32_t b = 0; b < nb; ++b) bvel_host.push_back(F4{u(g), u(g), u(g), 0.0f});
    bvel = toDevice(bvel_host.empty() ? std::vector<F4>(1) : bvel_host);
    bpressure = toDevice(std::vector<float>(std::max<uint32_t>(nb, 1), -1.0f));  // the pass must write every entry
    bmark = zeros<uint32_t>(std::max<uint32_t>(nb, 1));
    density = zeros<float>(n);
    pressure = zeros<float>(n);
    pterm = zeros<float>(n);
    nbr = toDevice(std::vector<uint32_t>(n * P.max_neighbours, 0xffffffffu));
    bnbr = toDevice(std::vector<uint32_t>(n * P.max_neighbours, 0xffffffffu));
    nbr_count = zeros<uint32_t>(n);
    bnbr_count = zeros<uint32_t>(n);
    snbr = toDevice(std::vector<uint32_t>(n * P.max_neighbours, 0xffffffffu));
    sbnbr = toDevice(std::vector<uint32_t>(n * P.max_neighbours, 0xffffffffu));
    snbr_count = zeros<uint32_t>(n);
    sbnbr_count = zeros<uint32_t>(n);
    overflow = zeros<uint32_t>(1);
    narrow_fail = zeros<uint32_t>(1);
    acc = zeros<F4>(n);
    crossings = zeros<uint32_t>(1);
    max_speed = zeros<uint32_t>(1);
  }

  void scan(const cl::Buffer& in, const cl::Buffer& out, uint32_t count) {
    const uint32_t chunk = (count + scan_chunks - 1) / scan_chunks;
    ks.call("scan_chunk_sums", scan_chunks, 0, count, chunk, in, scan_sums);
    ks.call("scan_chunk_offsets", 1, 0, scan_chunks, scan_sums);
    ks.call("scan_chunk_apply", scan_chunks, 0, count, chunk, scan_chunks, in, scan_sums, out);
  }

  // The grid build in parts, so that the test can look between the steps.
  void gridAssign() {
    const uint32_t zero = 0;
    clctx().queue().enqueueFillBuffer(cell_count, zero, 0, std::size_t(P.num_cells) * 4);
    ks.call("grid_assign", n, kLocal, P, pos[cur], cell, rank, cell_count);
  }
  void gridScan() { scan(cell_count, cell_start, P.num_cells); }
  void gridScatterOrder() {
    ks.call("grid_scatter", n, kLocal, P, cell, rank, cell_start, sorted);
    ks.call("grid_order_cells", n, kLocal, P, cell, cell_start, sorted);
  }
  void gridReorder() {
    const int nxt = 1 - cur;
    ks.call("grid_reorder", n, kLocal, P, sorted, pos[cur], vel[cur], colour[cur], phase[cur], id[cur], pos[nxt], vel[nxt], colour[nxt], phase[nxt], id[nxt]);
    cur = nxt;
  }
  void buildLists() {
    ks.call("build_neighbour_lists", n, kLocal, P, pos[cur], cell_start, bpos, bcell_start, nbr, nbr_count, bnbr, bnbr_count, overflow, list_radius > 0 ? list_radius : P.cell_size, narrow_fail);
  }
  /// A fluid list buffer (nbr or snbr) as n x max_neighbours indices: narrow lists
  /// (P.wide_lists = 0: 16-bit offsets j - i in the buffer's first half, kernels/shared/neighbours.h)
  /// decoded (only the first count entries of each list mean anything).
  std::vector<uint32_t> fluidLists(const cl::Buffer& b) const {
    const std::size_t K = P.max_neighbours;
    std::vector<uint32_t> raw = fromDevice<uint32_t>(b, n * K);
    if (P.wide_lists) return raw;
    std::vector<int16_t> off(n * K);
    std::memcpy(off.data(), raw.data(), off.size() * 2);
    std::vector<uint32_t> out(n * K);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < K; ++k) out[i * K + k] = static_cast<uint32_t>(static_cast<int64_t>(i) + off[i * K + k]);
    return out;
  }
  void buildGrid() {
    gridAssign();
    gridScan();
    gridScatterOrder();
    gridReorder();
    buildLists();
  }
  void computeDensity() {
    ++stamp;
    ks.call("compute_density", n, kLocal, P, pos[cur], phase[cur], bpos, nbr, nbr_count, bnbr, bnbr_count, density, pressure, pterm, snbr, snbr_count, sbnbr, sbnbr_count, stamp, bmark, 0);
  }
  void boundaryPressure() {
    if (nb > 0) ks.call("boundary_pressure", nb, kLocal, P, nb, stamp, bpos, bmark, pos[cur], density, pressure, cell_start, bpressure);
  }
  // As core/simulation.cpp: the wall pressure, then the force pass.
  // (`flags`: boundary velocities whose w marks moving bodies' particles; default bvel, all walls)
  void pressureForce(const cl::Buffer* flags = nullptr) {
    boundaryPressure();
    ks.call("pressure_force", n, kLocal, P, pos[cur], phase[cur], density, pterm, snbr, snbr_count, bpos,
            flags ? *flags : bvel, bpressure, sbnbr, sbnbr_count, acc);
  }
  void pressureViscosityForce() {
    boundaryPressure();
    ks.call("pressure_viscosity_force", n, kLocal, P, pos[cur], vel[cur], phase[cur], density, pterm, snbr, snbr_count,
            bpos, bvel, bpressure, sbnbr, sbnbr_count, acc);
  }
  void viscosityForce() {
    ks.call("viscosity_force", n, kLocal, P, pos[cur], vel[cur], phase[cur], density, snbr, snbr_count, bpos, bvel, sbnbr, sbnbr_count, acc);
  }
  void colourDiffuse() {
    ks.call("colour_diffuse", n, kLocal, P, pos[cur], phase[cur], density, colour[cur], snbr, snbr_count, colour[1 - cur]);
  }
  void integrate() {
    ks.call("integrate", n, kLocal, P, pos[cur], vel[cur], acc, crossings, max_speed);
  }
};

/// Counts failures and keeps the first few descriptions, so that a loop over thousands of
/// particles makes one assertion with a readable message.
struct Failures {
  std::size_t count = 0;
  std::ostringstream first;
  template <class Fn>
  void add(Fn&& describe) {
    if (count++ < 5) {
      describe(first);
      first << "\n";
    }
  }
};
#define CHECK_NO_FAILURES(f) \
  do {                       \
    INFO((f).first.str());   \
    CHECK((f).count == 0u);  \
    (f).count = 0;           \
    (f).first.str("");       \
  } while (0)

// ---------------------------------------------------------------------------------------------
// Scan
// ---------------------------------------------------------------------------------------------

TEST_CASE("scan kernels: exclusive prefix sum with the total, any chunking", "[kernels]") {
  KernelSet& ks = kernelSet(SPH_KERNEL_CUBIC_SPLINE, false);
  std::mt19937 g(11);
  // (n, chunks): one chunk; several; n not a multiple of the chunk; more chunks than needed (the
  // last chunks start at or past n); a single element.
  const std::pair<uint32_t, uint32_t> cases[] = {{1000, 1}, {5000, 5}, {4097, 5}, {9, 4}, {5, 4}, {6, 4}, {1, 1},
                                                 {100000, 98}};
  for (auto [n, chunks] : cases) {
    INFO("n = " << n << ", chunks = " << chunks);
    std::vector<uint32_t> in(n);
    for (auto& v : in) v = g() % 4 == 0 ? 0u : g() % 20;
    std::vector<uint32_t> expect(n + 1, 0u);
    std::exclusive_scan(in.begin(), in.end(), expect.begin(), 0u);
    expect[n] = expect[n - 1] + in[n - 1];
    cl::Buffer din = toDevice(in), dout = toDevice(std::vector<uint32_t>(n + 1, 0xdeadbeefu));
    cl::Buffer sums = toDevice(std::vector<uint32_t>(chunks + 1, 0xdeadbeefu));
    const uint32_t chunk = (n + chunks - 1) / chunks;
    ks["scan_chunk_sums"].setArg(0, n);
    ks["scan_chunk_sums"].setArg(1, chunk);
    ks["scan_chunk_sums"].setArg(2, din);
    ks["scan_chunk_sums"].setArg(3, sums);
    ks.enqueue("scan_chunk_sums", chunks);
    ks["scan_chunk_offsets"].setArg(0, chunks);
    ks["scan_chunk_offsets"].setArg(1, sums);
    ks.enqueue("scan_chunk_offsets", 1);
    ks["scan_chunk_apply"].setArg(0, n);
    ks["scan_chunk_apply"].setArg(1, chunk);
    ks["scan_chunk_apply"].setArg(2, chunks);
    ks["scan_chunk_apply"].setArg(3, din);
    ks["scan_chunk_apply"].setArg(4, sums);
    ks["scan_chunk_apply"].setArg(5, dout);
    ks.enqueue("scan_chunk_apply", chunks);
    const auto out = fromDevice<uint32_t>(dout, n + 1);
    CHECK(out == expect);
    CHECK(out[n] == std::accumulate(in.begin(), in.end(), 0u));
  }
}

// ---------------------------------------------------------------------------------------------
// Neighbour grid
// ---------------------------------------------------------------------------------------------

TEST_CASE("grid kernels: counts, scan, sorted permutation, deterministic order", "[kernels]") {
  for (const uint32_t chunk_cells : {1024u, 50u}) {  // one scan chunk, and many
    INFO("scan chunk of " << chunk_cells << " cells");
    const Scene s = makeScene(SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 3);
    const SimParams& P = s.P;
    const std::size_t n = s.pos.size(), cells = P.num_cells;
    Device d(kernelSet(SPH_KERNEL_CUBIC_SPLINE, false), s, chunk_cells);
    if (chunk_cells < 1024) CHECK(d.scan_chunks > 1);

    // grid_assign: the device cell is the host cell (except possibly on a cell face), counts per
    // cell, ranks a permutation of 0..count-1 within each cell.
    d.gridAssign();
    const auto cell = fromDevice<uint32_t>(d.cell, n);
    const auto rank = fromDevice<uint32_t>(d.rank, n);
    const auto count = fromDevice<uint32_t>(d.cell_count, cells);
    Failures f;
    std::vector<uint32_t> host_count(cells, 0u);
    std::vector<std::set<uint32_t>> ranks(cells);
    for (std::size_t i = 0; i < n; ++i) {
      if (cell[i] >= cells) {
        f.add([&](auto& o) { o << "particle " << i << ": cell " << cell[i] << " out of range"; });
        continue;
      }
      if (cell[i] != cellIndex(P, s.pos[i]) && !nearCellFace(P, s.pos[i]))
        f.add([&](auto& o) { o << "particle " << i << ": device cell " << cell[i] << ", host " << cellIndex(P, s.pos[i]); });
      ++host_count[cell[i]];
      ranks[cell[i]].insert(rank[i]);
    }
    CHECK_NO_FAILURES(f);
    CHECK(count == host_count);
    for (std::size_t c = 0; c < cells; ++c) {
      if (ranks[c].empty()) continue;
      if (ranks[c].size() != host_count[c] || *ranks[c].rbegin() != host_count[c] - 1)
        f.add([&](auto& o) { o << "cell " << c << ": ranks are not 0.." << host_count[c] - 1; });
    }
    CHECK_NO_FAILURES(f);

    // (a) the scan of the counts, with the total
    d.gridScan();
    const auto cell_start = fromDevice<uint32_t>(d.cell_start, cells + 1);
    std::vector<uint32_t> expect(cells + 1, 0u);
    std::exclusive_scan(count.begin(), count.end(), expect.begin(), 0u);
    expect[cells] = static_cast<uint32_t>(n);
    CHECK(cell_start == expect);

    // (b) scatter + order: sorted is the stable sort of the indices by cell (the order inside a
    // cell is by previous index, whatever order the atomics handed out ranks in)
    d.gridScatterOrder();
    const auto sorted = fromDevice<uint32_t>(d.sorted, n);
    std::vector<uint32_t> expect_sorted(n);
    std::iota(expect_sorted.begin(), expect_sorted.end(), 0u);
    std::stable_sort(expect_sorted.begin(), expect_sorted.end(),
                     [&](uint32_t a, uint32_t b) { return cell[a] < cell[b]; });
    CHECK(sorted == expect_sorted);
    std::vector<uint32_t> perm = sorted;
    std::sort(perm.begin(), perm.end());
    for (std::size_t i = 0; i < n; ++i)
      if (perm[i] != i) f.add([&](auto& o) { o << "sorted is not a permutation: " << i << " missing"; });
    for (std::size_t k = 0; k < n; ++k) {
      const uint32_t c = cell[sorted[k]];
      if (k < cell_start[c] || k >= cell_start[c + 1])
        f.add([&](auto& o) { o << "slot " << k << " holds a particle of cell " << c << " outside its range"; });
    }
    CHECK_NO_FAILURES(f);

    // grid_reorder gathers every field; the reordered positions are in cell order.
    d.gridReorder();
    const auto pos = fromDevice<F4>(d.pos[d.cur], n), vel = fromDevice<F4>(d.vel[d.cur], n);
    const auto col = fromDevice<F4>(d.colour[d.cur], n);
    const auto ph = fromDevice<uint32_t>(d.phase[d.cur], n), id = fromDevice<uint32_t>(d.id[d.cur], n);
    auto same = [](const F4& a, const F4& b) { return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w; };
    for (std::size_t k = 0; k < n; ++k) {
      const uint32_t j = sorted[k];
      if (!same(pos[k], s.pos[j]) || !same(vel[k], s.vel[j]) || !same(col[k], s.colour[j]) || ph[k] != s.phase[j] ||
          id[k] != s.id[j])
        f.add([&](auto& o) { o << "slot " << k << " does not hold particle " << j; });
      if (k > 0 && cellIndex(P, pos[k]) < cellIndex(P, pos[k - 1]) && !nearCellFace(P, pos[k]) &&
          !nearCellFace(P, pos[k - 1]))
        f.add([&](auto& o) { o << "slots " << k - 1 << ", " << k << " out of cell order"; });
    }
    CHECK_NO_FAILURES(f);

    // Building again from the sorted state is the identity (sorted input stays put), and a second
    // build from the same input gives the same bits.
    d.buildGrid();
    std::vector<uint32_t> identity(n);
    std::iota(identity.begin(), identity.end(), 0u);
    CHECK(fromDevice<uint32_t>(d.sorted, n) == identity);
    CHECK(fromDevice<uint32_t>(d.id[d.cur], n) == id);
    Device d2(kernelSet(SPH_KERNEL_CUBIC_SPLINE, false), s, chunk_cells);
    d2.buildGrid();
    CHECK(fromDevice<uint32_t>(d2.id[d2.cur], n) == id);
    CHECK(fromDevice<uint32_t>(d2.cell_start, cells + 1) == cell_start);
  }
}

// ---------------------------------------------------------------------------------------------
// Density, neighbour lists, pressure
// ---------------------------------------------------------------------------------------------

/// The grid-built state of a scene after compute_density, downloaded.
struct DensityState {
  std::vector<F4> pos, vel, colour;
  std::vector<uint32_t> phase;
  std::vector<float> density, pressure, pterm;
  std::vector<uint32_t> nbr, nbr_count, bnbr, bnbr_count;
  uint32_t overflow = 0;
};

/// Grid and lists, then (optionally) every particle moved by up to `move` (< skin / 2: the lists
/// stay valid), then compute_density; everything downloaded.
DensityState runDensity(Device& d, float move = 0.0f) {
  d.buildGrid();
  const std::size_t n = d.n, K = d.P.max_neighbours;
  if (move > 0.0f) {
    std::vector<F4> pos = fromDevice<F4>(d.pos[d.cur], n);
    std::mt19937 g(123);
    for (F4& x : pos) {
      float a, b, c;
      do {
        a = uni(g, -1, 1), b = uni(g, -1, 1), c = uni(g, -1, 1);
      } while (a * a + b * b + c * c > 1.0f);
      x.x += move * a;
      x.y += move * b;
      x.z += move * c;
    }
    write(d.pos[d.cur], pos);
  }
  d.computeDensity();
  DensityState st;
  st.pos = fromDevice<F4>(d.pos[d.cur], n);
  st.vel = fromDevice<F4>(d.vel[d.cur], n);
  st.colour = fromDevice<F4>(d.colour[d.cur], n);
  st.phase = fromDevice<uint32_t>(d.phase[d.cur], n);
  st.density = fromDevice<float>(d.density, n);
  st.pressure = fromDevice<float>(d.pressure, n);
  st.pterm = fromDevice<float>(d.pterm, n);
  st.nbr = d.fluidLists(d.nbr);
  st.nbr_count = fromDevice<uint32_t>(d.nbr_count, n);
  st.bnbr = fromDevice<uint32_t>(d.bnbr, n * K);
  st.bnbr_count = fromDevice<uint32_t>(d.bnbr_count, n);
  st.overflow = fromDevice<uint32_t>(d.overflow, 1)[0];
  return st;
}

/// Brute-force neighbours of x within R (self excluded by index `self`), and those in the
/// ambiguous band |r^2 - R^2| <= 1e-5 R^2.
void bruteNeighbours(const std::vector<F4>& pts, const F4& x, std::size_t self, float R, std::set<uint32_t>& in,
                     std::set<uint32_t>& band) {
  const float R2 = R * R;
  for (std::size_t j = 0; j < pts.size(); ++j) {
    if (j == self) continue;
    float a, b, c;
    const float r2 = dist2(x, pts[j], a, b, c);
    if (std::abs(r2 - R2) <= 1e-5f * R2)
      band.insert(static_cast<uint32_t>(j));
    else if (r2 < R2)
      in.insert(static_cast<uint32_t>(j));
  }
}

/// Compares one recorded neighbour list with the brute-force set.
void checkList(Failures& f, const char* what, std::size_t i, const uint32_t* list, uint32_t count,
               const std::set<uint32_t>& in, const std::set<uint32_t>& band) {
  std::set<uint32_t> got(list, list + count);
  if (got.size() != count) f.add([&](auto& o) { o << what << " list of " << i << " has duplicates"; });
  if (got.count(static_cast<uint32_t>(i)) && std::string(what) == "fluid")
    f.add([&](auto& o) { o << "fluid list of " << i << " holds itself"; });
  for (uint32_t j : got)
    if (!in.count(j) && !band.count(j)) f.add([&](auto& o) { o << what << " list of " << i << ": " << j << " is no neighbour"; });
  for (uint32_t j : in)
    if (!got.count(j)) f.add([&](auto& o) { o << what << " list of " << i << ": neighbour " << j << " missing"; });
}

// Every fluid particle's fluid and boundary lists after d.buildGrid() against brute force within
// `radius` (m), up to the float-rounding band; returns how many particles have a boundary neighbour.
std::size_t checkListsBruteForce(Device& d, const Scene& s, float radius) {
  const std::size_t n = d.n, K = s.P.max_neighbours;
  const auto pos = fromDevice<F4>(d.pos[d.cur], n);
  const auto nbr = d.fluidLists(d.nbr), nbr_count = fromDevice<uint32_t>(d.nbr_count, n);
  const auto bnbr = fromDevice<uint32_t>(d.bnbr, n * K), bnbr_count = fromDevice<uint32_t>(d.bnbr_count, n);
  REQUIRE(fromDevice<uint32_t>(d.overflow, 1)[0] == 0u);
  Failures f;
  std::size_t with_boundary = 0, total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::set<uint32_t> in, band, bin, bband;
    bruteNeighbours(pos, pos[i], i, radius, in, band);
    checkList(f, "fluid", i, &nbr[i * K], nbr_count[i], in, band);
    bruteNeighbours(s.bpos, pos[i], std::size_t(-1), radius, bin, bband);
    checkList(f, "boundary", i, &bnbr[i * K], bnbr_count[i], bin, bband);
    if (!bin.empty()) ++with_boundary;
    total += in.size();
  }
  INFO("mean neighbours within " << radius << " m: " << double(total) / n);
  CHECK_NO_FAILURES(f);
  return with_boundary;
}

TEST_CASE("build_neighbour_lists: fluid and boundary lists equal brute force within the list radius", "[kernels]") {
  struct Case {
    float ratio, skin;
    bool boundary;
  };
  for (const Case c : {Case{2.0f, 0.25f, true}, Case{2.0f, 0.0f, true}, Case{3.0f, 0.25f, true},
                       Case{2.0f, 0.25f, false}}) {
    INFO("H = " << c.ratio << " dx, skin " << c.skin << " H, boundary " << c.boundary);
    const Scene s = makeScene(SPH_KERNEL_CUBIC_SPLINE, c.ratio, c.boundary, SPH_EOS_LINEAR, false, 5, c.skin);
    const SimParams& P = s.P;
    Device d(kernelSet(SPH_KERNEL_CUBIC_SPLINE, false), s);
    d.buildGrid();
    const std::size_t with_boundary = checkListsBruteForce(d, s, P.cell_size);
    if (c.boundary) CHECK(with_boundary > d.n / 10);
    if (!c.boundary) CHECK(with_boundary == 0u);
  }
}

TEST_CASE("build_neighbour_lists at a radius below the cell size (DFSPH's lists of one step, at H) equal brute force",
          "[kernels]") {
  // Cells H + skin (skin H/4), lists at H: the 27 cells cover the radius; every pair within H,
  // none beyond (core/simulation.cpp buildGrid builds DFSPH's lists so when they expire anyway).
  const Scene s = makeScene(SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 5, 0.25f);
  const SimParams& P = s.P;
  Device d(kernelSet(SPH_KERNEL_CUBIC_SPLINE, false), s);
  d.list_radius = P.support;
  d.buildGrid();
  REQUIRE(P.support < 0.9f * P.cell_size);
  CHECK(checkListsBruteForce(d, s, P.support) > d.n / 10);
}

TEST_CASE("build_neighbour_lists: overflowing lists keep max_neighbours entries and report the largest count",
          "[kernels]") {
  Scene s = makeScene(SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 9);
  s.P.max_neighbours = 8;
  Device d(kernelSet(SPH_KERNEL_CUBIC_SPLINE, false), s);
  d.buildGrid();
  const std::size_t n = s.pos.size(), K = 8;
  const auto pos = fromDevice<F4>(d.pos[d.cur], n);
  const auto nbr = d.fluidLists(d.nbr), nbr_count = fromDevice<uint32_t>(d.nbr_count, n);
  const auto bnbr = fromDevice<uint32_t>(d.bnbr, n * K), bnbr_count = fromDevice<uint32_t>(d.bnbr_count, n);
  const uint32_t overflow = fromDevice<uint32_t>(d.overflow, 1)[0];
  const float R = s.P.cell_size;
  Failures f;
  uint32_t lo = 0, hi = 0;  // expected overflow value, bounds from the ambiguous band
  for (std::size_t i = 0; i < n; ++i) {
    std::set<uint32_t> in, band, bin, bband;
    bruteNeighbours(pos, pos[i], i, R, in, band);
    bruteNeighbours(s.bpos, pos[i], std::size_t(-1), R, bin, bband);
    const std::size_t cmin = std::max(in.size(), bin.size());
    const std::size_t cmax = std::max(in.size() + band.size(), bin.size() + bband.size());
    if (cmin > K) lo = std::max<uint32_t>(lo, static_cast<uint32_t>(cmin));
    if (cmax > K) hi = std::max<uint32_t>(hi, static_cast<uint32_t>(cmax));
    if (nbr_count[i] != std::min(in.size(), K) && band.empty())
      f.add([&](auto& o) { o << i << ": count " << nbr_count[i] << " of " << in.size(); });
    if (bnbr_count[i] != std::min(bin.size(), K) && bband.empty())
      f.add([&](auto& o) { o << i << ": boundary count " << bnbr_count[i] << " of " << bin.size(); });
    for (uint32_t k = 0; k < nbr_count[i]; ++k)
      if (!in.count(nbr[i * K + k]) && !band.count(nbr[i * K + k])) f.add([&](auto& o) { o << i << ": bad entry"; });
    for (uint32_t k = 0; k < bnbr_count[i]; ++k)
      if (!bin.count(bnbr[i * K + k]) && !bband.count(bnbr[i * K + k]))
        f.add([&](auto& o) { o << i << ": bad boundary entry"; });
  }
  CHECK_NO_FAILURES(f);
  CHECK(lo > K);
  CHECK(overflow >= lo);
  CHECK(overflow <= hi);
}

struct DensityCase {
  int kind;
  float ratio;
  bool boundary;
  uint32_t eos;
  bool clamp;
  float move = 0.0f;  // displacement after the lists were built, as a fraction of the skin
};

TEST_CASE("compute_density: density, EOS and p / delta^2 equal the brute-force reference", "[kernels]") {
  const DensityCase cases[] = {
      {SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false},
      {SPH_KERNEL_WENDLAND_C2, 3.0f, true, SPH_EOS_TAIT, true},
      {SPH_KERNEL_CUBIC_SPLINE, 2.0f, false, SPH_EOS_TAIT, false},  // no boundary: all-zero bcell_start
      {SPH_KERNEL_WENDLAND_C2, 2.0f, true, SPH_EOS_LINEAR, true},
      // particles moved by up to 0.49 skin after the lists were built: the lists still hold every
      // pair now within H (Verlet), so the density still equals brute force
      {SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_TAIT, false, 0.49f},
  };
  for (const DensityCase& c : cases) {
    INFO(kindName(c.kind) << ", H = " << c.ratio << " dx, boundary " << c.boundary << ", eos " << c.eos << ", clamp "
                          << c.clamp << ", moved " << c.move << " skin");
    const Scene s = makeScene(c.kind, c.ratio, c.boundary, c.eos, c.clamp, 5);
    const SimParams& P = s.P;
    Device d(kernelSet(c.kind, false), s);
    const DensityState st = runDensity(d, c.move * (P.cell_size - P.support));
    const std::size_t n = s.pos.size();
    const float H = P.support, H2 = H * H;
    REQUIRE(st.overflow == 0u);

    Failures dens, pres, pterm;
    std::size_t negative = 0, positive = 0;
    for (std::size_t i = 0; i < n; ++i) {
      // number density over all j (self included) and all boundary particles
      double nd = 0.0;
      for (std::size_t j = 0; j < n; ++j) {
        float a, b, e;
        const float r2 = dist2(st.pos[i], st.pos[j], a, b, e);
        if (r2 < H2) nd += sph_w(c.kind, std::sqrt(r2), H);
      }
      for (const F4& bb : s.bpos) {
        float a, b, e;
        const float r2 = dist2(st.pos[i], bb, a, b, e);
        if (r2 < H2) nd += bb.w * static_cast<double>(sph_w(c.kind, std::sqrt(r2), H));
      }
      const double m = P.phase_mass[st.phase[i]];
      const double rho = m * nd;
      // all terms positive: the float sum is within ~n eps of it (n <= 200), 1e-5 relative
      if (!(std::abs(st.density[i] - rho) <= 1e-5 * rho))
        dens.add([&](auto& o) { o << "particle " << i << ": density " << st.density[i] << ", reference " << rho; });

      // EOS of the device's density (so that density errors are not counted twice); compared
      // relative to the magnitude of its terms, which cancel near rest
      const double rd = st.density[i], rho0 = P.phase_rest_density[st.phase[i]], c2 = double(P.c0) * P.c0;
      double p, scale;
      if (c.eos == SPH_EOS_TAIT) {
        const double r7 = std::pow(rd / rho0, 7.0), B = c2 * rho0 / 7.0;
        p = B * (r7 - 1.0);
        scale = B * (r7 + 1.0);
      } else {
        p = c2 * (rd - rho0);
        scale = c2 * (rd + rho0);
      }
      (p < 0 ? negative : positive)++;
      if (c.clamp) p = std::max(p, 0.0);
      if (!(std::abs(st.pressure[i] - p) <= 1e-5 * scale) || (c.clamp && st.pressure[i] < 0.0f))
        pres.add([&](auto& o) { o << "particle " << i << ": pressure " << st.pressure[i] << ", reference " << p; });
      // p / delta^2 with delta = rho / m the number density: a few roundings of the device's values
      const double dd = rd / m, pt = st.pressure[i] / (dd * dd);
      if (!(std::abs(st.pterm[i] - pt) <= 1e-5 * std::abs(pt)))
        pterm.add([&](auto& o) { o << "particle " << i << ": p / delta^2 " << st.pterm[i] << ", reference " << pt; });
    }
    CHECK_NO_FAILURES(dens);
    CHECK_NO_FAILURES(pres);
    CHECK_NO_FAILURES(pterm);
    // the scene exercises what it should: both signs of pressure
    CHECK(negative > 0u);
    CHECK(positive > 0u);
  }
}

// DFSPH's factor pass sums the density too where the lists are this step's (core/simulation.cpp,
// computeDensity; performance): it must give compute_density's values exactly, so that the two paths
// leave every particle bitwise the same, and the factors of the density it computed.
TEST_CASE("dfsph_factor with the density: compute_density's density, pressure, p / delta^2 and marks, bitwise",
          "[kernels][dfsph]") {
  const DensityCase cases[] = {
      {SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false},
      {SPH_KERNEL_WENDLAND_C2, 3.0f, true, SPH_EOS_TAIT, true},
      {SPH_KERNEL_CUBIC_SPLINE, 2.0f, false, SPH_EOS_TAIT, false},
  };
  for (const DensityCase& c : cases) {
    INFO(kindName(c.kind) << ", H = " << c.ratio << " dx, boundary " << c.boundary << ", eos " << c.eos);
    const Scene s = makeScene(c.kind, c.ratio, c.boundary, c.eos, c.clamp, 5);
    Device d(kernelSet(c.kind, false), s);
    REQUIRE(runDensity(d).overflow == 0u);  // Verlet lists, then compute_density writes this step's lists
    const std::size_t n = d.n, nbc = std::max<std::size_t>(d.nb, 1);
    // compute_density on this step's lists, as the simulation runs it where the fused pass would (step_lists)
    write(d.bmark, std::vector<uint32_t>(nbc, 0u));
    d.ks.call("compute_density", n, kLocal, d.P, d.pos[d.cur], d.phase[d.cur], d.bpos, d.snbr, d.snbr_count, d.sbnbr,
              d.sbnbr_count, d.density, d.pressure, d.pterm, d.snbr, d.snbr_count, d.sbnbr, d.sbnbr_count, d.stamp,
              d.bmark, 1);
    const std::vector<float> density = fromDevice<float>(d.density, n), pressure = fromDevice<float>(d.pressure, n),
                             pterm = fromDevice<float>(d.pterm, n);
    const std::vector<uint32_t> marks = fromDevice<uint32_t>(d.bmark, nbc);
    const cl::Buffer alpha = zeros<float>(n), alpha2 = zeros<float>(n), rate = zeros<float>(n);
    const cl::Buffer gwall = zeros<F4>(n);
    auto factor = [&](int with_density, const cl::Buffer& a) {
      d.ks.call("dfsph_factor", n, kLocal, d.P, d.pos[d.cur], d.phase[d.cur], d.density, d.snbr, d.snbr_count, d.bpos,
                d.sbnbr, d.sbnbr_count, 1.0f, a, d.bvel, gwall, 1, d.vel[d.cur], rate, 0, 0, gwall, with_density,
                d.pressure, d.pterm, d.stamp, d.bmark);
    };
    factor(0, alpha);  // the factors of compute_density's density
    // the outputs overwritten with values the pass must replace, the marks cleared
    write(d.density, std::vector<float>(n, -7.0f));
    write(d.pressure, std::vector<float>(n, -7.0f));
    write(d.pterm, std::vector<float>(n, -7.0f));
    write(d.bmark, std::vector<uint32_t>(nbc, 0u));
    factor(1, alpha2);
    auto same = [](const std::vector<float>& a, const std::vector<float>& b) {
      return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * 4) == 0;
    };
    CHECK(same(fromDevice<float>(d.density, n), density));
    CHECK(same(fromDevice<float>(d.pressure, n), pressure));
    CHECK(same(fromDevice<float>(d.pterm, n), pterm));
    CHECK(fromDevice<uint32_t>(d.bmark, nbc) == marks);
    CHECK(same(fromDevice<float>(alpha2, n), fromDevice<float>(alpha, n)));
    // the scene exercises the marks where it has a boundary
    if (c.boundary) CHECK(std::count(marks.begin(), marks.end(), d.stamp) > 0);
  }
}

// The pair passes take sixteen neighbours at a time and add each half of the sixteen terms to the eight-wide
// sums in turn (kernels/shared/pair_loops.h): the eight-wide loop's operations in its order, so its bits.
// The program built with -DSPH_PAIR16=0 (eight at a time only) must give every output byte for byte.
/// Outputs of several passes, each as its bytes.
struct PassBytes {
  std::vector<std::vector<unsigned char>> bytes;
  template <class T>
  void add(const cl::Buffer& b, std::size_t count) {
    const std::vector<T> v = fromDevice<T>(b, count);
    bytes.emplace_back(reinterpret_cast<const unsigned char*>(v.data()),
                       reinterpret_cast<const unsigned char*>(v.data()) + v.size() * sizeof(T));
  }
};

void checkSixteenWide(const int kind, const bool laminar) {
  const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
  INFO(kindName(kind) << ", " << (laminar ? "laminar" : "artificial"));
  const Scene s = makeScene(kind, ratio, true, SPH_EOS_TAIT, false, 41);
  KernelSet& k16 = kernelSet(kind, laminar);
  KernelSet& k8 = kernelSet(kind, laminar, " -DSPH_PAIR16=0");
  Device d(k16, s);
  REQUIRE(runDensity(d, 0.3f * (s.P.cell_size - s.P.support)).overflow == 0u);
  const std::size_t n = d.n, nbc = std::max<std::size_t>(d.nb, 1);
  // the passes must meet lists of sixteen and more, and lists of fewer
  const std::vector<uint32_t> counts = fromDevice<uint32_t>(d.snbr_count, n);
  CHECK(std::count_if(counts.begin(), counts.end(), [](uint32_t c) { return c >= 16; }) > 10);
  CHECK(std::count_if(counts.begin(), counts.end(), [](uint32_t c) { return c < 16; }) > 0);
  std::mt19937 g(9);
  std::vector<F4> xt_host = fromDevice<F4>(d.pos[d.cur], n), acc_host(n);
  std::vector<float> p_host(n), alpha_host(n), src_host(n);
  for (std::size_t i = 0; i < n; ++i) {
    xt_host[i].w = uni(g, 0.0f, 3e-3f);  // p_j / delta_j^2 as the force pass reads it
    acc_host[i] = F4{uni(g, -5, 5), uni(g, -5, 5), uni(g, -5, 5), 0.0f};
    p_host[i] = uni(g, 0.0f, 2000.0f);
    alpha_host[i] = uni(g, 1e-8f, 1e-7f);
    src_host[i] = uni(g, -1e-3f, 1e-3f);
  }
  auto run = [&](KernelSet& ks) {
    PassBytes o;
    const cl::Buffer acc = zeros<F4>(n);
    ks.call("pressure_force", n, kLocal, d.P, d.pos[d.cur], d.phase[d.cur], d.density, d.pterm, d.snbr, d.snbr_count,
            d.bpos, d.bvel, d.bpressure, d.sbnbr, d.sbnbr_count, acc);
    o.add<F4>(acc, n);
    ks.call("viscosity_force", n, kLocal, d.P, d.pos[d.cur], d.vel[d.cur], d.phase[d.cur], d.density, d.snbr,
            d.snbr_count, d.bpos, d.bvel, d.sbnbr, d.sbnbr_count, acc);
    o.add<F4>(acc, n);
    // the factor pass with the density and the density rate, every phase's mass gathered (one_mass 0)
    const cl::Buffer density = toDevice(fromDevice<float>(d.density, n)), pressure = zeros<float>(n),
                     pterm = zeros<float>(n), bmark = zeros<uint32_t>(nbc), alpha = zeros<float>(n),
                     rate = zeros<float>(n), gwall = zeros<F4>(n);
    ks.call("dfsph_factor", n, kLocal, d.P, d.pos[d.cur], d.phase[d.cur], density, d.snbr, d.snbr_count, d.bpos,
            d.sbnbr, d.sbnbr_count, 1.0f, alpha, d.bvel, gwall, 1, d.vel[d.cur], rate, 0, 0, gwall, 1, pressure, pterm,
            d.stamp + 1, bmark);
    for (const cl::Buffer* b : {&density, &pressure, &pterm, &alpha, &rate}) o.add<float>(*b, n);
    o.add<F4>(gwall, n);
    // the solves' passes on the same made-up pressures and accelerations
    const cl::Buffer xt = toDevice(xt_host), pr = toDevice(p_host), accel = zeros<F4>(n), bpr = zeros<float>(nbc);
    ks.call("dfsph_pressure_accel", n, kLocal, d.P, xt, d.phase[d.cur], density, pr, d.snbr, d.snbr_count, d.bpos,
            d.sbnbr, d.sbnbr_count, 1.0f, bpr, 0, accel, gwall);
    o.add<F4>(accel, n);
    const cl::Buffer accel2 = toDevice(acc_host), alpha2 = toDevice(alpha_host), src = toDevice(src_host),
                     pr2 = toDevice(p_host), err = zeros<float>(n), xt2 = zeros<F4>(n), pold = toDevice(p_host);
    ks.call("dfsph_jacobi", n, kLocal, d.P, d.pos[d.cur], accel2, alpha2, src, d.snbr, d.snbr_count, d.bpos, d.sbnbr,
            d.sbnbr_count, 0u, 0.5f, 1, pr2, err, d.phase[d.cur], density, xt2, gwall, 0, accel2, 0.9f, pold);
    for (const cl::Buffer* b : {&pr2, &err, &pold}) o.add<float>(*b, n);
    o.add<F4>(xt2, n);
    const cl::Buffer vel = toDevice(fromDevice<F4>(d.vel[d.cur], n));
    ks.call("dfsph_apply_pressure", n, kLocal, d.P, xt, vel, d.phase[d.cur], density, pr, d.snbr, d.snbr_count, d.bpos,
            d.sbnbr, d.sbnbr_count, 1.0f, bpr, 0, gwall);
    o.add<F4>(vel, n);
    return o;
  };
  const PassBytes a = run(k16), b = run(k8);
  const char* names[] = {"pressure_force",   "viscosity_force", "factor: density",   "factor: pressure",
                         "factor: p / delta^2", "factor: alpha", "factor: rate",      "factor: wall sums",
                         "pressure_accel",   "jacobi: pressure", "jacobi: error",     "jacobi: previous",
                         "jacobi: xt",       "apply_pressure"};
  REQUIRE(a.bytes.size() == std::size(names));
  for (std::size_t q = 0; q < a.bytes.size(); ++q) {
    INFO(names[q]);
    CHECK(a.bytes[q] == b.bytes[q]);
  }
  // and the outputs are not trivially equal: the passes wrote non-zero values
  CHECK(std::any_of(a.bytes[8].begin(), a.bytes[8].end(), [](unsigned char c) { return c != 0; }));
}

TEST_CASE("pair passes sixteen at a time give the eight-wide loops' results bitwise (artificial viscosity)",
          "[kernels][dfsph]") {
  checkSixteenWide(SPH_KERNEL_CUBIC_SPLINE, false);
  checkSixteenWide(SPH_KERNEL_WENDLAND_C2, false);
}

TEST_CASE("pair passes sixteen at a time give the eight-wide loops' results bitwise (laminar viscosity)",
          "[kernels][dfsph]") {
  checkSixteenWide(SPH_KERNEL_CUBIC_SPLINE, true);
}

// The density solve's start with extrapolated walls (core/dfsph.cpp, DfsphSolver::source): dfsph_warm_pack
// and dfsph_source_accel give the bits of dfsph_source (kind 1, warm_all) and of the first iteration's
// dfsph_pressure_accel (with the walls' own pressures) on the same values.
TEST_CASE("dfsph_warm_pack + dfsph_source_accel equal dfsph_source + dfsph_pressure_accel bitwise", "[kernels][dfsph]") {
  for (const int kind : {SPH_KERNEL_CUBIC_SPLINE, SPH_KERNEL_WENDLAND_C2}) {
    const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
    INFO(kindName(kind));
    const Scene s = makeScene(kind, ratio, true, SPH_EOS_TAIT, false, 43);
    KernelSet& ks = kernelSet(kind, false);
    Device d(ks, s);
    REQUIRE(runDensity(d, 0.3f * (s.P.cell_size - s.P.support)).overflow == 0u);
    const std::size_t n = d.n, nbc = std::max<std::size_t>(d.nb, 1);
    REQUIRE(d.nb > 0u);
    auto P = d.P;
    P.dt = 2e-3f;  // s
    // the wall sums of the factor pass, and made-up warm pressures (Pa) and wall pressures (Pa)
    const cl::Buffer density = toDevice(fromDevice<float>(d.density, n)), alpha = zeros<float>(n),
                     rate = zeros<float>(n), gwall = zeros<F4>(n), pterm = zeros<float>(n),
                     fpress = zeros<float>(n), bmark = zeros<uint32_t>(nbc);
    ks.call("dfsph_factor", n, kLocal, P, d.pos[d.cur], d.phase[d.cur], density, d.snbr, d.snbr_count, d.bpos,
            d.sbnbr, d.sbnbr_count, 1.0f, alpha, d.bvel, gwall, 0, d.vel[d.cur], rate, 0, 0, gwall, 0, fpress, pterm,
            d.stamp + 1, bmark);
    std::mt19937 g(17);
    std::vector<float> p_host(n), bp_host(nbc);
    for (auto& v : p_host) v = uni(g, 0.0f, 2000.0f);
    for (auto& v : bp_host) v = uni(g, 0.0f, 2000.0f);
    const cl::Buffer bpr = toDevice(bp_host);
    const float warm = 0.75f;
    // separate: dfsph_source (kind 1, no neighbour-count rule, warm_all), then dfsph_pressure_accel
    const cl::Buffer pa = toDevice(p_host), xa = zeros<F4>(n), sa = zeros<float>(n), aa = zeros<F4>(n);
    ks.call("dfsph_source", n, kLocal, P, d.pos[d.cur], d.vel[d.cur], d.phase[d.cur], density, d.snbr, d.snbr_count,
            d.bpos, d.bvel, d.sbnbr, d.sbnbr_count, 1, 0u, warm, 1, sa, pa, xa, gwall, 0);
    ks.call("dfsph_pressure_accel", n, kLocal, P, xa, d.phase[d.cur], density, pa, d.snbr, d.snbr_count, d.bpos,
            d.sbnbr, d.sbnbr_count, 1.0f, bpr, 1, aa, gwall);
    // together: dfsph_warm_pack, then dfsph_source_accel
    const cl::Buffer pb = toDevice(p_host), xb = zeros<F4>(n), sb = zeros<float>(n), ab = zeros<F4>(n);
    ks.call("dfsph_warm_pack", n, kLocal, P, d.pos[d.cur], d.phase[d.cur], density, warm, pb, xb);
    ks.call("dfsph_source_accel", n, kLocal, P, xb, d.vel[d.cur], d.phase[d.cur], density, pb, d.snbr, d.snbr_count,
            d.bpos, d.sbnbr, d.sbnbr_count, 1.0f, bpr, 1, ab, gwall, sb);
    const auto same = [](const auto& x, const auto& y) {
      return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
    };
    CHECK(same(fromDevice<float>(pa, n), fromDevice<float>(pb, n)));
    CHECK(same(fromDevice<F4>(xa, n), fromDevice<F4>(xb, n)));
    CHECK(same(fromDevice<float>(sa, n), fromDevice<float>(sb, n)));
    const std::vector<F4> acc = fromDevice<F4>(ab, n);
    CHECK(same(fromDevice<F4>(aa, n), acc));
    // not trivially equal: sources and accelerations that are not all zero, and walls that took part
    const std::vector<float> src = fromDevice<float>(sb, n);
    CHECK(std::count_if(src.begin(), src.end(), [](float v) { return v != 0.0f; }) > 10);
    CHECK(std::count_if(acc.begin(), acc.end(), [](const F4& a) { return a.x != 0.0f || a.z != 0.0f; }) > 10);
    const std::vector<uint32_t> bc = fromDevice<uint32_t>(d.sbnbr_count, n);
    CHECK(std::count_if(bc.begin(), bc.end(), [](uint32_t c) { return c > 0; }) > 10);
  }
}

// ---------------------------------------------------------------------------------------------
// Forces
// ---------------------------------------------------------------------------------------------

struct Vec {
  double x = 0, y = 0, z = 0;
  Vec& operator+=(const Vec& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  double norm() const { return norm3(x, y, z); }
};
Vec operator*(double s, const Vec& v) { return {s * v.x, s * v.y, s * v.z}; }

TEST_CASE("pressure_force equals the brute-force reference (fluid, boundary and contact terms)", "[kernels]") {
  for (const DensityCase& c : {DensityCase{SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false},
                               DensityCase{SPH_KERNEL_WENDLAND_C2, 3.0f, true, SPH_EOS_TAIT, true},
                               DensityCase{SPH_KERNEL_CUBIC_SPLINE, 2.0f, false, SPH_EOS_TAIT, false},
                               DensityCase{SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 0.49f}}) {
    INFO(kindName(c.kind) << ", H = " << c.ratio << " dx, boundary " << c.boundary << ", moved " << c.move << " skin");
    const Scene s = makeScene(c.kind, c.ratio, c.boundary, c.eos, c.clamp, 21);
    const SimParams& P = s.P;
    Device d(kernelSet(c.kind, false), s);
    const DensityState st = runDensity(d, c.move * (P.cell_size - P.support));
    REQUIRE(st.overflow == 0u);
    // Every other boundary particle a moving body's (bvel.w = 1): its contact range is dx/2, the
    // walls' dx (pair_loops.h, sph_boundary_contact).
    std::vector<F4> flags = d.bvel_host;
    for (std::size_t b = 0; b < flags.size(); b += 2) flags[b].w = 1.0f;
    const cl::Buffer flag_buffer = toDevice(flags.empty() ? std::vector<F4>(1) : flags);
    d.pressureForce(&flag_buffer);
    const auto acc = fromDevice<F4>(d.acc, d.n);
    const std::size_t n = d.n;
    const float H = P.support, H2 = H * H;
    const float dx = std::cbrt(P.rest_volume);
    const double kc = 5.0 * double(P.c0) * P.c0 / dx;
    std::size_t body_contacts = 0;

    // Wall pressures (Adami et al. 2012 eq. 27, pressure.cl's boundary_pressure), brute force.
    std::vector<double> pb(s.bpos.size(), 0.0);
    const auto pb_device = fromDevice<float>(d.bpressure, std::max<std::size_t>(s.bpos.size(), 1));
    std::size_t walls_pressed = 0;
    Failures fb;
    for (std::size_t b = 0; b < s.bpos.size(); ++b) {
      double sw = 0, spw = 0;
      Vec srw;
      for (std::size_t j = 0; j < n; ++j) {
        float rx, ry, rz;
        const float r2 = dist2(s.bpos[b], st.pos[j], rx, ry, rz);
        if (!(r2 < H2)) continue;
        const double w = sph_w(c.kind, std::sqrt(r2), H);
        sw += w;
        spw += st.pressure[j] * w;
        srw += (st.density[j] * w) * Vec{rx, ry, rz};
      }
      const double gr = P.gravity[0] * srw.x + P.gravity[1] * srw.y + P.gravity[2] * srw.z;
      pb[b] = sw > 0 ? (spw + gr) / sw : 0.0;
      if (P.clamp_negative_pressure) pb[b] = std::max(0.0, pb[b]);  // as the fluid's pressure
      walls_pressed += pb[b] > 0;
      // float sums of positive terms (the extrapolation may cancel: scale by its magnitude)
      const double tol = 1e-5 * (sw > 0 ? (std::abs(spw) + std::abs(gr)) / sw : 0.0) + 1e-30;
      if (!(std::abs(pb_device[b] - pb[b]) <= tol))
        fb.add([&](auto& o) { o << "boundary particle " << b << ": device " << pb_device[b] << " Pa, reference " << pb[b] << " (sum W " << sw << ", sum p W " << spw << ", g . sum rho r W " << gr << ")"; });
    }
    CHECK_NO_FAILURES(fb);
    if (c.boundary) CHECK(walls_pressed > 10u);

    std::vector<Vec> ref(n);
    std::vector<double> scale(n);
    double amax = 0.0;
    std::size_t contacts = 0;
    for (std::size_t i = 0; i < n; ++i) {
      // p / delta^2 as the density pass wrote it (checked against its reference there)
      const double mi = P.phase_mass[st.phase[i]];
      const double pi_term = st.pterm[i];
      Vec f, contact;
      double fs = 0.0, cs = 0.0;
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        float a, b, e;
        const float r2 = dist2(st.pos[i], st.pos[j], a, b, e);
        if (!(r2 < H2)) continue;
        const double pj_term = st.pterm[j];
        const double F = sph_grad_factor(c.kind, std::sqrt(r2), H);
        f += (-(pi_term + pj_term) * F) * Vec{a, b, e};
        fs += (std::abs(pi_term) + std::abs(pj_term)) * std::abs(F) * std::sqrt(double(r2));  // terms may cancel
      }
      for (const F4& bb : s.bpos) {
        float a, b, e;
        const float r2 = dist2(st.pos[i], bb, a, b, e);
        if (!(r2 < H2)) continue;
        const float r = std::sqrt(r2);
        // the symmetric term with the wall pressure (pressure.cl's header)
        const std::size_t k = static_cast<std::size_t>(&bb - s.bpos.data());
        const double inv_delta = mi / st.density[i];
        const double coef = -bb.w * (pi_term + pb[k] * inv_delta * inv_delta) * sph_grad_factor(c.kind, r, H);
        f += coef * Vec{a, b, e};
        fs += std::abs(coef) * r;
        const bool body = flags[k].w > 0.5f;
        const float r0 = body ? 0.5f * dx : dx;
        if (r < r0 && r > 1e-6f * dx) {
          contact += (bb.w * kc * (1.0 - double(r) / r0) / r) * Vec{a, b, e};
          cs += bb.w * kc;  // (1 - r/r0) cancels: its rounding scales with the coefficient
          ++contacts;
          body_contacts += body;
        }
      }
      ref[i] = (1.0 / mi) * f;
      ref[i] += contact;
      ref[i] += Vec{P.gravity[0], P.gravity[1], P.gravity[2]};
      scale[i] = fs / mi + cs + 9.81;
      amax = std::max(amax, ref[i].norm());
    }
    Failures f;
    double worst_rel_scale = 0.0, worst_rel_max = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double err = norm3(acc[i].x - ref[i].x, acc[i].y - ref[i].y, acc[i].z - ref[i].z);
      worst_rel_scale = std::max(worst_rel_scale, err / scale[i]);
      worst_rel_max = std::max(worst_rel_max, err / amax);
      // within 1e-5 of the particle's term scale (float sum bound, see the top) and within 1e-4
      // of the largest acceleration of the scene
      if (!(err <= 1e-5 * scale[i] && err <= 1e-4 * amax) || acc[i].w != 0.0f)
        f.add([&](auto& o) {
          o << "particle " << i << ": device (" << acc[i].x << ", " << acc[i].y << ", " << acc[i].z << "), reference ("
            << ref[i].x << ", " << ref[i].y << ", " << ref[i].z << "), scale " << scale[i];
        });
    }
    INFO("worst error / term scale " << worst_rel_scale << ", / max |a| " << worst_rel_max);
    CHECK_NO_FAILURES(f);
    INFO(body_contacts << " of " << contacts << " contacts with body particles");
    if (c.boundary) CHECK(contacts > 0u);
  }
}

// DFSPH's extrapolated walls read each iteration's wall pressure from per-step lists of the fluid
// near each wall particle (kernels/dfsph.cl, dfsph_wall_lists, dfsph_wall_list_pressure): the same
// pairs in the same order as boundary_pressure, so the same bits; a list longer than its slots
// falls back to the cells.
TEST_CASE("dfsph_wall_list_pressure equals boundary_pressure bitwise (listed and overflowing lists)", "[kernels]") {
  for (const DensityCase& c : {DensityCase{SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 0.49f},
                               DensityCase{SPH_KERNEL_WENDLAND_C2, 3.0f, true, SPH_EOS_TAIT, true}}) {
    INFO(kindName(c.kind) << ", H = " << c.ratio << " dx, clamp " << c.clamp << ", moved " << c.move << " skin");
    const Scene s = makeScene(c.kind, c.ratio, c.boundary, c.eos, c.clamp, 23);
    Device d(kernelSet(c.kind, false), s);
    runDensity(d, c.move * (d.P.cell_size - d.P.support));
    REQUIRE(d.nb > 0u);
    d.boundaryPressure();
    const auto reference = fromDevice<float>(d.bpressure, d.nb);
    for (const uint32_t slots : {32u, 4u}) {
      INFO("slots " << slots);
      cl::Buffer wlist = toDevice(std::vector<uint32_t>(std::size_t(d.nb) * slots, 0xffffffffu));
      cl::Buffer wcount = toDevice(std::vector<uint32_t>(d.nb, 0xdeadbeefu));  // every entry written
      cl::Buffer out = toDevice(std::vector<float>(d.nb, -1.0f));
      cl::Buffer other = toDevice(std::vector<float>(d.nb, -1.0f));  // the other solve's wall pressures
      cl::Buffer n_active = toDevice(std::vector<uint32_t>(1, 0u));
      cl::Buffer active = toDevice(std::vector<uint32_t>(d.nb, 0xffffffffu));
      // the lists, the active wall particles and 0 for the others; then the pressure of the active ones
      cl::Buffer weight = toDevice(std::vector<float>(std::size_t(d.nb) * slots, -1.0f));
      cl::Buffer sums = toDevice(std::vector<float>(std::size_t(d.nb) * 4, -1.0f));
      d.ks.call("dfsph_wall_lists", d.nb, kLocal, d.P, d.nb, d.stamp, d.bpos, d.bmark, d.pos[d.cur], d.cell_start,
                slots, wlist, wcount, out, other, n_active, active, d.density, weight, sums);
      const uint32_t na = fromDevice<uint32_t>(n_active, 1)[0];
      CHECK(na > 0u);
      if (na > 0)
        d.ks.call("dfsph_wall_list_pressure", na, kLocal, d.P, na, active, d.bpos, d.pos[d.cur], d.density,
                  d.pressure, d.cell_start, slots, wlist, wcount, out, weight, sums);
      const auto got = fromDevice<float>(out, d.nb);
      const auto count = fromDevice<uint32_t>(wcount, d.nb);
      std::size_t listed = 0, overflowing = 0, pressed = 0;
      Failures f;
      for (uint32_t b = 0; b < d.nb; ++b) {
        listed += count[b] > 0 && count[b] <= slots;
        overflowing += count[b] > slots;
        pressed += reference[b] != 0.0f;
        if (std::memcmp(&got[b], &reference[b], 4) != 0)
          f.add([&](auto& o) { o << "boundary particle " << b << " (" << count[b] << " listed): " << got[b] << " Pa, boundary_pressure " << reference[b]; });
      }
      CHECK_NO_FAILURES(f);
      // both paths ran: lists within their slots, and (with 4 slots) lists that overflowed
      CHECK(listed > 10u);
      CHECK(pressed > 10u);
      if (slots == 4u) CHECK(overflowing > 10u);
    }
  }
}

TEST_CASE("gravity_only writes gravity", "[kernels]") {
  KernelSet& ks = kernelSet(SPH_KERNEL_CUBIC_SPLINE, false);
  SimParams P{};
  P.n_fluid = 100;
  P.gravity[0] = 0.5f;
  P.gravity[1] = -1.0f;
  P.gravity[2] = -9.81f;
  cl::Buffer acc = toDevice(std::vector<F4>(128, F4{7, 7, 7, 7}));
  ks["gravity_only"].setArg(0, sizeof(SimParams), &P);
  ks["gravity_only"].setArg(1, acc);
  ks.enqueue("gravity_only", P.n_fluid, kLocal);
  const auto a = fromDevice<F4>(acc, 128);
  for (std::size_t i = 0; i < 128; ++i) {
    const bool active = i < P.n_fluid;
    CHECK(a[i].x == (active ? 0.5f : 7.0f));
    CHECK(a[i].y == (active ? -1.0f : 7.0f));
    CHECK(a[i].z == (active ? -9.81f : 7.0f));
    CHECK(a[i].w == (active ? 0.0f : 7.0f));
  }
}

void checkViscosity(const bool laminar, const int kind) {
  {
    const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
    INFO(kindName(kind) << ", " << (laminar ? "laminar" : "artificial"));
    const Scene s = makeScene(kind, ratio, true, SPH_EOS_LINEAR, false, 33);
    const SimParams& P = s.P;
    Device d(kernelSet(kind, laminar), s);
    const DensityState st = runDensity(d);
    REQUIRE(st.overflow == 0u);
    const std::size_t n = d.n;
    // viscosity adds to what the pressure stage wrote: start from known values
    std::mt19937 g(44);
    std::vector<F4> acc0(n);
    for (auto& a : acc0) a = {uni(g, -1, 1), uni(g, -1, 1), uni(g, -1, 1), 0.0f};
    write(d.acc, acc0);
    d.viscosityForce();
    const auto acc = fromDevice<F4>(d.acc, n);

    const float H = P.support, H2 = H * H;
    const double h = P.h, eta2 = 0.01 * h * h;
    Failures f;
    double amax = 0.0;
    std::vector<Vec> ref(n);
    std::vector<double> scale(n);
    std::size_t active_pairs = 0, boundary_pairs = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double rhoi = st.density[i], mui = rhoi * P.phase_viscosity[st.phase[i]];
      Vec a;
      double as = 0.0;
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        float x, y, z;
        const float r2 = dist2(st.pos[i], st.pos[j], x, y, z);
        if (!(r2 < H2)) continue;
        const Vec vij{double(st.vel[i].x) - st.vel[j].x, double(st.vel[i].y) - st.vel[j].y,
                      double(st.vel[i].z) - st.vel[j].z};
        const double mj = P.phase_mass[st.phase[j]], rhoj = st.density[j];
        const double F = sph_grad_factor(kind, std::sqrt(r2), H);
        Vec term;
        if (laminar) {
          const double muj = rhoj * P.phase_viscosity[st.phase[j]];
          term = (mj * (mui + muj) / (rhoi * rhoj) * (F * r2) / (r2 + eta2)) * vij;
        } else {
          const double vx = vij.x * x + vij.y * y + vij.z * z;
          if (!(vx < 0.0)) continue;
          const double mu = h * vx / (r2 + eta2);
          const double Pi = -double(P.alpha) * P.c0 * mu / (0.5 * (rhoi + rhoj));
          term = (-mj * Pi * F) * Vec{x, y, z};
        }
        a += term;
        as += term.norm();
        ++active_pairs;
      }
      // boundary particles, moving with d.bvel_host: a fluid particle of mass (V_b / V0) m_i with
      // the particle's own density and viscosity (Akinci et al. 2012 eq. 11; pair_loops.h)
      const double mi = P.phase_mass[st.phase[i]], nui = P.phase_viscosity[st.phase[i]];
      for (std::size_t b = 0; b < s.bpos.size(); ++b) {
        float x, y, z;
        const float r2 = dist2(st.pos[i], s.bpos[b], x, y, z);
        if (!(r2 < H2)) continue;
        const F4& vb = d.bvel_host[b];
        const Vec vib{double(st.vel[i].x) - vb.x, double(st.vel[i].y) - vb.y, double(st.vel[i].z) - vb.z};
        const double F = sph_grad_factor(kind, std::sqrt(r2), H), w = s.bpos[b].w;
        Vec term;
        if (laminar) {
          term = (2.0 * w * mi * nui / rhoi * (F * r2) / (r2 + eta2)) * vib;
        } else {
          const double vx = vib.x * x + vib.y * y + vib.z * z;
          if (!(vx < 0.0)) continue;
          const double Pi = -double(P.alpha) * P.c0 * h * vx / ((r2 + eta2) * rhoi);
          term = (-w * mi * Pi * F) * Vec{x, y, z};
        }
        a += term;
        as += term.norm();
        ++boundary_pairs;
      }
      ref[i] = a;
      scale[i] = as;
      amax = std::max(amax, a.norm());
    }
    double worst_rel_scale = 0.0, worst_rel_max = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec expect{acc0[i].x + ref[i].x, acc0[i].y + ref[i].y, acc0[i].z + ref[i].z};
      const double err = norm3(acc[i].x - expect.x, acc[i].y - expect.y, acc[i].z - expect.z);
      // the sum's rounding (1e-5 of its term scale) plus the final float addition to acc (2 ulp)
      const double tol_scale = 1e-5 * scale[i] + 2.4e-7 * (expect.norm() + ref[i].norm());
      worst_rel_scale = std::max(worst_rel_scale, err / (scale[i] + 1e-30));
      worst_rel_max = std::max(worst_rel_max, err / amax);
      if (!(err <= tol_scale && err <= 1e-4 * amax + 2.4e-7 * expect.norm()))
        f.add([&](auto& o) {
          o << "particle " << i << ": device (" << acc[i].x << ", " << acc[i].y << ", " << acc[i].z
            << "), reference (" << expect.x << ", " << expect.y << ", " << expect.z << "), scale " << scale[i];
        });
    }
    INFO("max |a_visc| " << amax << ", worst error / term scale " << worst_rel_scale << ", / max " << worst_rel_max);
    CHECK_NO_FAILURES(f);
    CHECK(active_pairs > n);
    CHECK(boundary_pairs > 10u);
    CHECK(amax > 1.0);  // the viscous accelerations are not negligible next to acc0
  }
}

// One test case per program (each builds one on a cold pocl cache, ~2 s).
TEST_CASE("viscosity_force (artificial, Monaghan), cubic spline, equals the brute-force reference", "[kernels]") {
  checkViscosity(false, SPH_KERNEL_CUBIC_SPLINE);
}

TEST_CASE("viscosity_force (artificial, Monaghan), Wendland C2, equals the brute-force reference", "[kernels]") {
  checkViscosity(false, SPH_KERNEL_WENDLAND_C2);
}

TEST_CASE("viscosity_force (laminar, Morris, -DSPH_LAMINAR=1), cubic spline, equals the brute-force reference",
          "[kernels]") {
  checkViscosity(true, SPH_KERNEL_CUBIC_SPLINE);
}

TEST_CASE("viscosity_force (laminar, Morris, -DSPH_LAMINAR=1), Wendland C2, equals the brute-force reference",
          "[kernels]") {
  checkViscosity(true, SPH_KERNEL_WENDLAND_C2);
}

// The fused pass must give what the two separate passes give (each checked against its
// brute-force reference above): the same float terms, summed in the same order, so equal to the
// last bit in principle; allow 2 ulp of the larger magnitude for the compiler's freedom to
// contract a * b + c into an FMA differently in the two kernels.
void checkFused(const bool laminar, const int kind) {
  const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
  INFO(kindName(kind) << ", " << (laminar ? "laminar" : "artificial"));
  const Scene s = makeScene(kind, ratio, true, SPH_EOS_TAIT, false, 35);
  Device d(kernelSet(kind, laminar), s);
  const DensityState st = runDensity(d, 0.3f * (s.P.cell_size - s.P.support));
  REQUIRE(st.overflow == 0u);
  d.pressureForce();
  d.viscosityForce();
  const auto separate = fromDevice<F4>(d.acc, d.n);
  write(d.acc, std::vector<F4>(d.n, F4{7, 7, 7, 7}));
  d.pressureViscosityForce();
  const auto fused = fromDevice<F4>(d.acc, d.n);
  Failures f;
  double amax = 0.0;
  for (std::size_t i = 0; i < d.n; ++i) {
    const float* a = &separate[i].x;
    const float* b = &fused[i].x;
    amax = std::max(amax, norm3(a[0], a[1], a[2]));
    for (int c = 0; c < 4; ++c) {
      const float tol = 2.0f * std::numeric_limits<float>::epsilon() * std::max(std::abs(a[c]), std::abs(b[c]));
      if (!(std::abs(a[c] - b[c]) <= tol))
        f.add([&](auto& o) { o << "particle " << i << " component " << c << ": separate " << a[c] << ", fused " << b[c]; });
    }
  }
  CHECK_NO_FAILURES(f);
  CHECK(amax > 1.0);
}

TEST_CASE("pressure_viscosity_force equals pressure_force then viscosity_force (artificial)", "[kernels]") {
  checkFused(false, SPH_KERNEL_CUBIC_SPLINE);
  checkFused(false, SPH_KERNEL_WENDLAND_C2);
}

TEST_CASE("pressure_viscosity_force equals pressure_force then viscosity_force (laminar)", "[kernels]") {
  checkFused(true, SPH_KERNEL_CUBIC_SPLINE);
  checkFused(true, SPH_KERNEL_WENDLAND_C2);
}

// The implicit viscosity's kernels (kernels/viscosity.cl, viscosity_cg_*): conjugate gradients driven
// from the host as DfsphSolver::viscositySolve drives them, to a tight tolerance, must give the solution
// of the backward-Euler system written out on the host in double from its definition (Morris' pair
// terms of the brute-force viscosity reference above, every pair within H found by brute force):
//     (1 + dt sum_j k_ij + dt sum_b k_ib) x_i - dt sum_j k_ij x_j = v_i + dt sum_b k_ib v_b,
// solved by dense LU, one right-hand side per component. The scene's two phases (nu 1e-3 and
// 1e-2 m^2/s) and random fluid and boundary velocities, at a step 10x the explicit bound
// 0.125 h^2 / nu of the more viscous phase, so that the implicit system is far from the identity.
// Then viscosity_cg_finish turns the solution into the acceleration (x - v) / dt added to acc.
// Measured (session 37): 15 / 14 iterations, worst |x - x_ref| 3.6e-7 / 5.9e-7 m/s against tolerances
// 2.6e-5 / 2.3e-5 (cubic spline / Wendland C2). Mutation: the boundary's k_ib left out of the diagonal in
// viscosity_cg_setup: worst 1.9 / 2.5 m/s, fails.
void checkViscosityCg(const int kind) {
  const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
  INFO(kindName(kind));
  Scene s = makeScene(kind, ratio, true, SPH_EOS_LINEAR, false, 37);
  s.P.dt = 10.0f * 0.125f * s.P.h * s.P.h / s.P.phase_viscosity[1];
  const SimParams& P = s.P;
  Device d(kernelSet(kind, true), s);
  const DensityState st = runDensity(d);
  REQUIRE(st.overflow == 0u);
  const std::size_t n = d.n;
  auto& ks = d.ks;
  cl::Buffer diag = zeros<float>(n), x = zeros<F4>(n), r = zeros<F4>(n), z = zeros<F4>(n), dir = zeros<F4>(n),
             q = zeros<F4>(n), dots = zeros<float>(n);
  auto sum = [&](const cl::Buffer& b) {
    double t = 0.0;
    for (float v : fromDevice<float>(b, n)) t += v;
    return t;
  };
  ks.call("viscosity_cg_setup", n, kLocal, P, d.pos[d.cur], d.vel[d.cur], d.phase[d.cur], d.density, d.snbr,
          d.snbr_count, d.bpos, d.bvel, d.sbnbr, d.sbnbr_count, diag, x, r, z, dir, dots);
  double rz = sum(dots);
  const double rz0 = rz;
  int iterations = 0;
  while (rz > 1e-14 * rz0 && iterations < 500) {
    ks.call("viscosity_cg_apply", n, kLocal, P, d.pos[d.cur], d.phase[d.cur], d.density, d.snbr, d.snbr_count, diag, dir,
            q, dots);
    const double dq = sum(dots);
    REQUIRE(dq > 0.0);  // M A is positive definite
    ks.call("viscosity_cg_update", n, kLocal, P, static_cast<float>(rz / dq), d.phase[d.cur], diag, dir, q, x, r, z, dots);
    const double rz_new = sum(dots);
    ++iterations;
    const float beta = static_cast<float>(rz_new / rz);
    rz = rz_new;
    if (rz <= 1e-14 * rz0) break;
    ks.call("viscosity_cg_direction", n, kLocal, P, beta, z, dir);
  }
  const auto xd = fromDevice<F4>(x, n);

  // The system from its definition, in double.
  const double H = P.support, H2 = H * H, eta2 = 0.01 * double(P.h) * P.h, dt = P.dt;
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd b(n, 3);
  double kmax = 0.0;  // the largest dt sum_j k_ij of a row (off-diagonal mass)
  std::size_t pairs = 0, boundary_pairs = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double rhoi = st.density[i], nui = P.phase_viscosity[st.phase[i]], mui = rhoi * nui;
    const double mi = P.phase_mass[st.phase[i]];
    b.row(i) = Eigen::RowVector3d(st.vel[i].x, st.vel[i].y, st.vel[i].z);
    double row = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      float ex, ey, ez;
      const float r2 = dist2(st.pos[i], st.pos[j], ex, ey, ez);
      if (!(r2 < H2)) continue;
      const double rhoj = st.density[j], muj = rhoj * P.phase_viscosity[st.phase[j]];
      const double F = sph_grad_factor(kind, std::sqrt(r2), H);
      const double k = -P.phase_mass[st.phase[j]] * (mui + muj) / (rhoi * rhoj) * F * r2 / (r2 + eta2);
      A(i, i) += dt * k;
      A(i, j) -= dt * k;
      row += dt * k;
      ++pairs;
    }
    for (std::size_t bb = 0; bb < s.bpos.size(); ++bb) {
      float ex, ey, ez;
      const float r2 = dist2(st.pos[i], s.bpos[bb], ex, ey, ez);
      if (!(r2 < H2)) continue;
      const double F = sph_grad_factor(kind, std::sqrt(r2), H);
      const double k = -2.0 * s.bpos[bb].w * mi * nui / rhoi * F * r2 / (r2 + eta2);
      const F4& vb = d.bvel_host[bb];
      A(i, i) += dt * k;
      b.row(i) += dt * k * Eigen::RowVector3d(vb.x, vb.y, vb.z);
      ++boundary_pairs;
    }
    kmax = std::max(kmax, row);
  }
  const Eigen::MatrixXd xref = A.partialPivLu().solve(b);
  // Tolerance: float arithmetic. Each row of A x sums ~35-110 terms in float: its rounding is ~1e-6 of the
  // row's scale, which is up to (1 + 2 kmax) max |x| (Gershgorin). The solution's error is that residual
  // times |A^-1|, and A = I + dt L with M L symmetric positive semidefinite has its (generalized)
  // eigenvalues >= 1, so |A^-1| <= 1 in the mass norm (x 1.2 in the plain norm for the phases' mass
  // ratio 1000 / 700). So |x - x_ref| <= 2e-6 (1 + 2 kmax) max |x|.
  double xmax = 0.0, worst = 0.0, change = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    xmax = std::max(xmax, xref.row(i).norm());
    change = std::max(change, (xref.row(i) - Eigen::RowVector3d(st.vel[i].x, st.vel[i].y, st.vel[i].z)).norm());
  }
  const double tol = 2e-6 * (1.0 + 2.0 * kmax) * xmax;
  Failures f;
  for (std::size_t i = 0; i < n; ++i) {
    const double err = (Eigen::RowVector3d(xd[i].x, xd[i].y, xd[i].z) - xref.row(i)).norm();
    worst = std::max(worst, err);
    if (!(err <= tol))
      f.add([&](auto& o) {
        o << "particle " << i << ": device (" << xd[i].x << ", " << xd[i].y << ", " << xd[i].z << "), reference ("
          << xref(i, 0) << ", " << xref(i, 1) << ", " << xref(i, 2) << ")";
      });
  }
  INFO(iterations << " CG iterations; largest dt sum_j k_ij " << kmax << "; largest |x - v| " << change
                  << " m/s of max |x| " << xmax << "; worst |x - x_ref| " << worst << " against " << tol);
  CHECK_NO_FAILURES(f);
  CHECK(kmax > 1.0);         // the step is long against the viscous time: the system is not near the identity
  CHECK(change > 0.1 * xmax);  // and the solve moves the velocities
  CHECK(pairs > n);
  CHECK(boundary_pairs > 10u);
  CHECK(iterations < 500);

  // viscosity_cg_finish: acc += (x - v) / dt.
  std::mt19937 g(45);
  std::vector<F4> acc0(n);
  for (auto& a : acc0) a = {uni(g, -1, 1), uni(g, -1, 1), uni(g, -1, 1), 0.0f};
  write(d.acc, acc0);
  ks.call("viscosity_cg_finish", n, kLocal, P, d.vel[d.cur], x, d.acc);
  const auto acc = fromDevice<F4>(d.acc, n);
  for (std::size_t i = 0; i < n; ++i) {
    const double ax = acc0[i].x + (double(xd[i].x) - st.vel[i].x) / dt, ay = acc0[i].y + (double(xd[i].y) - st.vel[i].y) / dt,
                 az = acc0[i].z + (double(xd[i].z) - st.vel[i].z) / dt;
    const double e = norm3(acc[i].x - ax, acc[i].y - ay, acc[i].z - az), scale = norm3(ax, ay, az) + xmax / dt;
    if (!(e <= 1e-6 * scale)) f.add([&](auto& o) { o << "acc of particle " << i << ": " << acc[i].x << " against " << ax; });
  }
  CHECK_NO_FAILURES(f);
  WARN("viscosity CG, " << kindName(kind) << ": " << iterations << " iterations, dt sum k up to " << kmax
                        << ", worst |x - x_ref| " << worst << " m/s (tolerance " << tol << ", max |x| " << xmax << ")");
}

TEST_CASE("viscosity_cg_* (implicit laminar viscosity), cubic spline: CG gives the dense backward-Euler solution",
          "[kernels]") {
  checkViscosityCg(SPH_KERNEL_CUBIC_SPLINE);
}

TEST_CASE("viscosity_cg_* (implicit laminar viscosity), Wendland C2: CG gives the dense backward-Euler solution",
          "[kernels]") {
  checkViscosityCg(SPH_KERNEL_WENDLAND_C2);
}

TEST_CASE("colour_diffuse equals the brute-force reference", "[kernels]") {
  for (const int kind : kKinds) {
    INFO(kindName(kind));
    const float ratio = kind == SPH_KERNEL_WENDLAND_C2 ? 3.0f : 2.0f;
    Scene s = makeScene(kind, ratio, true, SPH_EOS_LINEAR, false, 55);
    for (std::size_t i = 0; i < s.colour.size(); ++i) s.colour[i].w = 0.25f + 0.5f * (i % 2);  // kept as is
    s.P.colour_diffusion = 2e-2f;  // strong enough that one step changes colours by a few percent
    const SimParams& P = s.P;
    Device d(kernelSet(kind, false), s);
    const DensityState st = runDensity(d);
    REQUIRE(st.overflow == 0u);
    d.colourDiffuse();
    const std::size_t n = d.n;
    const auto out = fromDevice<F4>(d.colour[1 - d.cur], n);
    const float H = P.support, H2 = H * H;
    const double eta2 = 0.01 * double(P.h) * P.h, k = double(P.dt) * P.colour_diffusion;
    Failures f;
    double max_change = 0.0;
    std::size_t clamped = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double lap[3] = {0, 0, 0}, sc[3] = {0, 0, 0};
      const F4& ci = st.colour[i];
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        float x, y, z;
        const float r2 = dist2(st.pos[i], st.pos[j], x, y, z);
        if (!(r2 < H2)) continue;
        const double dj = st.density[j] / double(P.phase_mass[st.phase[j]]);
        const double w = 2.0 / dj * sph_grad_factor(kind, std::sqrt(r2), H) * r2 / (r2 + eta2);
        const F4& cj = st.colour[j];
        const double dc[3] = {double(ci.x) - cj.x, double(ci.y) - cj.y, double(ci.z) - cj.z};
        for (int a = 0; a < 3; ++a) {
          lap[a] += w * dc[a];
          sc[a] += std::abs(w * dc[a]);
        }
      }
      const float in[3] = {ci.x, ci.y, ci.z}, got[3] = {out[i].x, out[i].y, out[i].z};
      for (int a = 0; a < 3; ++a) {
        const double raw = in[a] + k * lap[a];
        const double expect = std::min(1.0, std::max(0.0, raw));
        if (raw != expect) ++clamped;
        max_change = std::max(max_change, std::abs(expect - in[a]));
        // 1e-5 of the term scale (float sum bound) plus 2 ulp of the colour in [0, 1]
        if (!(std::abs(got[a] - expect) <= 1e-5 * k * sc[a] + 2.4e-7))
          f.add([&](auto& o) {
            o << "particle " << i << " channel " << a << ": device " << got[a] << ", reference " << expect;
          });
      }
      if (out[i].w != ci.w) f.add([&](auto& o) { o << "particle " << i << ": w changed"; });
    }
    INFO("largest colour change " << max_change << ", clamped channels " << clamped);
    CHECK_NO_FAILURES(f);
    CHECK(max_change > 0.01);  // the step changes colours measurably
  }
}

// ---------------------------------------------------------------------------------------------
// Integration and diagnostics
// ---------------------------------------------------------------------------------------------

TEST_CASE("integrate: symplectic Euler, closed walls put particles back and count them, max speed", "[kernels]") {
  KernelSet& ks = kernelSet(SPH_KERNEL_CUBIC_SPLINE, false);
  SimParams P{};
  P.cell_size = 0.04f;
  for (int a = 0; a < 3; ++a) {
    P.domain_min[a] = 0.0f;
    P.domain_max[a] = 0.5f;
  }
  P.closed_mask = (1u << 0) | (1u << 1) | (1u << 4);  // x_min, x_max, z_min closed; y and z_max open
  P.dt = 1e-3f;
  std::mt19937 g(77);
  std::vector<F4> pos, vel, acc;
  for (int i = 0; i < 300; ++i) {
    pos.push_back({uni(g, 0.05f, 0.45f), uni(g, 0.05f, 0.45f), uni(g, 0.05f, 0.45f), 3.0f});
    vel.push_back({uni(g, -2, 2), uni(g, -2, 2), uni(g, -2, 2), 5.0f});
    acc.push_back({uni(g, -100, 100), uni(g, -100, 100), uni(g, -100, 100), 9.0f});
  }
  // special particles: [index] = what happens
  pos[0] = {0.001f, 0.2f, 0.2f, 0};    vel[0] = {-5, 0, 0, 0};   acc[0] = {0, 0, 0, 0};      // x_min: back, counted
  pos[1] = {0.2f, 0.2f, 0.002f, 0};    vel[1] = {1, 0, -3, 0};   acc[1] = {0, 0, -9.81f, 0}; // z_min
  pos[2] = {0.499f, 0.2f, 0.2f, 0};    vel[2] = {5, 1, 0, 0};    acc[2] = {0, 0, 0, 0};      // x_max (closed)
  pos[3] = {0.2f, 0.499f, 0.2f, 0};    vel[3] = {0, 5, 0, 0};    acc[3] = {0, 0, 0, 0};      // y_max open: leaves
  pos[4] = {0.001f, 0.2f, 0.001f, 0};  vel[4] = {-4, 0, -4, 0};  acc[4] = {0, 0, 0, 0};      // two walls: counted once
  pos[5] = {0.2f, -0.1f, 0.2f, 0};     vel[5] = {0, -1, 0, 0};   acc[5] = {0, 0, 0, 0};      // outside an open wall
  pos[6] = {-0.1f, 0.2f, 0.2f, 0};     vel[6] = {1, 0, 0, 0};    acc[6] = {0, 0, 0, 0};      // behind x_min, moving in
  pos[7] = {0.2f, 0.2f, 0.499f, 0};    vel[7] = {0, 0, 5, 0};    acc[7] = {0, 0, 0, 0};      // z_max open: leaves
  const std::size_t n = pos.size() - 3;  // the last 3 are past n_fluid and must stay untouched
  P.n_fluid = static_cast<sph_uint>(n);
  cl::Buffer dpos = toDevice(pos), dvel = toDevice(vel), dacc = toDevice(acc);
  cl::Buffer dcross = toDevice(std::vector<uint32_t>{7u});  // counts on top of what is there
  float vmax0 = 0.5f;                                        // a max to be raised, bits as the kernel keeps it
  uint32_t vmax0_bits;
  std::memcpy(&vmax0_bits, &vmax0, 4);
  cl::Buffer dvmax = toDevice(std::vector<uint32_t>{vmax0_bits});
  ks["integrate"].setArg(0, sizeof(SimParams), &P);
  ks["integrate"].setArg(1, dpos);
  ks["integrate"].setArg(2, dvel);
  ks["integrate"].setArg(3, dacc);
  ks["integrate"].setArg(4, dcross);
  ks["integrate"].setArg(5, dvmax);
  ks.enqueue("integrate", n, kLocal);
  const auto x = fromDevice<F4>(dpos, pos.size()), v = fromDevice<F4>(dvel, pos.size());
  const uint32_t crossings = fromDevice<uint32_t>(dcross, 1)[0];
  const uint32_t vmax_bits = fromDevice<uint32_t>(dvmax, 1)[0];
  float vmax_dev;
  std::memcpy(&vmax_dev, &vmax_bits, 4);
  double vmax_ref = vmax0;

  const float eps = 1e-4f * P.cell_size;
  Failures f;
  uint32_t expect_cross = 0;
  for (std::size_t i = 0; i < pos.size(); ++i) {
    float ev[3], ex[3];
    const float x0[3] = {pos[i].x, pos[i].y, pos[i].z}, v0[3] = {vel[i].x, vel[i].y, vel[i].z},
                a0[3] = {acc[i].x, acc[i].y, acc[i].z};
    bool crossed = false;
    for (int a = 0; a < 3; ++a) {
      ev[a] = v0[a] + P.dt * a0[a];
      ex[a] = x0[a] + P.dt * ev[a];
      if (((P.closed_mask >> (2 * a)) & 1u) && ex[a] < P.domain_min[a])
        ex[a] = P.domain_min[a] + eps, ev[a] = std::max(ev[a], 0.0f), crossed = true;
      if (((P.closed_mask >> (2 * a + 1)) & 1u) && ex[a] > P.domain_max[a])
        ex[a] = P.domain_max[a] - eps, ev[a] = std::min(ev[a], 0.0f), crossed = true;
    }
    if (i >= n) {  // untouched
      if (x[i].x != pos[i].x || x[i].w != pos[i].w || v[i].x != vel[i].x || v[i].w != vel[i].w)
        f.add([&](auto& o) { o << "particle " << i << " past n_fluid was written"; });
      continue;
    }
    if (crossed) ++expect_cross;
    vmax_ref = std::max(vmax_ref, norm3(ev[0], ev[1], ev[2]));
    const float gx[3] = {x[i].x, x[i].y, x[i].z}, gv[3] = {v[i].x, v[i].y, v[i].z};
    for (int a = 0; a < 3; ++a) {
      // each value is 2 float roundings (v + dt a, x + dt v), fused or not: a few ulp of the
      // operands, bounded by 1e-6 relative to |x| + dt |v| and |v| + dt |a|
      const float tx = 1e-6f * (std::abs(x0[a]) + P.dt * std::abs(ev[a]) + 1e-6f);
      const float tv = 1e-6f * (std::abs(v0[a]) + P.dt * std::abs(a0[a]) + 1e-6f);
      if (!(std::abs(gx[a] - ex[a]) <= tx && std::abs(gv[a] - ev[a]) <= tv))
        f.add([&](auto& o) {
          o << "particle " << i << " axis " << a << ": x " << gx[a] << " (reference " << ex[a] << "), v " << gv[a]
            << " (reference " << ev[a] << ")";
        });
    }
    if (x[i].w != 0.0f || v[i].w != 0.0f) f.add([&](auto& o) { o << "particle " << i << ": w not zeroed"; });
  }
  CHECK_NO_FAILURES(f);
  CHECK(expect_cross == 5u);  // particles 0, 1, 2, 4, 6
  CHECK(crossings == 7u + expect_cross);
  // the put-back particles are inside, moving no further out
  CHECK(x[0].x == Approx(eps).margin(1e-9));
  CHECK(v[0].x == 0.0f);
  CHECK(x[2].x == Approx(0.5f - eps).margin(1e-7));
  CHECK(v[2].x == 0.0f);
  CHECK(x[1].z == Approx(eps).margin(1e-9));
  CHECK(v[6].x == Approx(1.0f));
  CHECK(x[3].y > 0.5f);
  CHECK(x[7].z > 0.5f);
  // the step's largest speed (after the walls), raised from the initial value (few ulp: length())
  CHECK(vmax_dev == Approx(vmax_ref).epsilon(1e-6));
  CHECK(vmax_ref > 4.0);
}

TEST_CASE("diagnostics: non-finite, outside, CFL counts, max speed and first bad index per chunk", "[kernels]") {
  KernelSet& ks = kernelSet(SPH_KERNEL_CUBIC_SPLINE, false);
  SimParams P{};
  for (int a = 0; a < 3; ++a) {
    P.domain_min[a] = 0.0f;
    P.domain_max[a] = 1.0f;
  }
  P.dt = 1e-3f;
  P.h = 0.01f;  // CFL violation: speed > h / dt = 10 m/s
  const std::size_t n = 100, groups = 4, chunk = 25;
  P.n_fluid = static_cast<sph_uint>(n);
  std::mt19937 g(99);
  std::vector<F4> pos(n), vel(n);
  std::vector<float> density(n, 1000.0f);
  for (std::size_t i = 0; i < n; ++i) {
    pos[i] = {uni(g, 0.1f, 0.9f), uni(g, 0.1f, 0.9f), uni(g, 0.1f, 0.9f), 0};
    vel[i] = {uni(g, -2, 2), uni(g, -2, 2), uni(g, -2, 2), 0};
  }
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  pos[10].y = 1.5f;          // group 0: outside
  pos[12].z = -0.1f;         // group 0: outside, not the first
  pos[30].x = nan;           // group 1: non-finite position
  vel[33].z = inf;           // group 1: non-finite velocity
  vel[60] = {12, 0, 0, 0};   // group 2: CFL violation, max speed 12
  density[80] = nan;         // group 3: non-finite density
  cl::Buffer dpos = toDevice(pos), dvel = toDevice(vel), dden = toDevice(density);
  cl::Buffer out = toDevice(std::vector<uint32_t>(groups * 8, 0xdeadbeefu));
  ks.call("diagnostics", groups, 0, P, static_cast<uint32_t>(chunk), dpos, dvel, dden, out);
  const auto r = fromDevice<uint32_t>(out, groups * 8);
  auto fbits = [](uint32_t b) {
    float v;
    std::memcpy(&v, &b, 4);
    return v;
  };
  auto vmax = [&](std::size_t g0) {
    float m = 0.0f;
    for (std::size_t i = g0 * chunk; i < (g0 + 1) * chunk; ++i) {
      const float s = std::sqrt(vel[i].x * vel[i].x + vel[i].y * vel[i].y + vel[i].z * vel[i].z);
      if (std::isfinite(pos[i].x) && std::isfinite(s) && std::isfinite(density[i])) m = std::max(m, s);
    }
    return m;
  };
  const uint32_t expect[4][6] = {{0, 2, 0, 0, 0, 10}, {2, 0, 0, 0, 0, 30}, {0, 0, 1, 0, 0, 0xffffffffu},
                                 {1, 0, 0, 0, 0, 80}};
  for (std::size_t g0 = 0; g0 < groups; ++g0) {
    INFO("group " << g0);
    CHECK(r[g0 * 8 + 0] == expect[g0][0]);
    CHECK(r[g0 * 8 + 1] == expect[g0][1]);
    CHECK(r[g0 * 8 + 2] == expect[g0][2]);
    CHECK(r[g0 * 8 + 5] == expect[g0][5]);
    CHECK(fbits(r[g0 * 8 + 4]) == Approx(vmax(g0)).epsilon(1e-6));
  }
  CHECK(fbits(r[2 * 8 + 4]) == Approx(12.0f));
}

}  // namespace

TEST_CASE("boundary_ghost_velocity equals the brute-force reference (Adami et al. 2012 eq. 22-23)", "[kernels]") {
  // No-slip ghost velocities (viscosity.cl): for each boundary particle the fluid saw this step,
  // 2 v_b - sum_f v_f W_bf / sum_f W_bf; its own velocity where unseen, or (mode 2) where it is not
  // a moving body's particle (w = 0). Every other boundary particle is made a body particle here.
  const DensityCase c{SPH_KERNEL_CUBIC_SPLINE, 2.0f, true, SPH_EOS_LINEAR, false, 0.49f};
  const Scene s = makeScene(c.kind, c.ratio, c.boundary, c.eos, c.clamp, 21);
  const SimParams& P = s.P;
  Device d(kernelSet(c.kind, false), s);
  const DensityState st = runDensity(d, c.move * (P.cell_size - P.support));
  REQUIRE(st.overflow == 0u);
  std::vector<F4> bv = d.bvel_host;
  for (std::size_t b = 0; b < bv.size(); b += 2) bv[b].w = 1.0f;
  const cl::Buffer bvel = toDevice(bv);
  const auto marks = fromDevice<uint32_t>(d.bmark, d.nb);
  const float H = P.support, H2 = H * H;
  for (const uint32_t mode : {1u, 2u}) {
    INFO("mode " << mode);
    cl::Buffer out = zeros<F4>(d.nb);
    d.ks.call("boundary_ghost_velocity", d.nb, kLocal, P, d.nb, d.stamp, mode, d.bpos, bvel, d.bmark, d.pos[d.cur],
              d.vel[d.cur], d.cell_start, out);
    const auto got = fromDevice<F4>(out, d.nb);
    std::size_t mirrored = 0;
    Failures fb;
    for (std::size_t b = 0; b < bv.size(); ++b) {
      double sw = 0, vmax = 0;
      Vec svw;
      for (std::size_t j = 0; j < d.n; ++j) {
        float rx, ry, rz;
        if (!(dist2(s.bpos[b], st.pos[j], rx, ry, rz) < H2)) continue;
        const double w = sph_w(c.kind, std::sqrt(dist2(s.bpos[b], st.pos[j], rx, ry, rz)), H);
        sw += w;
        svw += w * Vec{st.vel[j].x, st.vel[j].y, st.vel[j].z};
        vmax = std::max(vmax, norm3(st.vel[j].x, st.vel[j].y, st.vel[j].z));
      }
      const bool mirror = marks[b] == d.stamp && sw > 0 && (mode == 1u || bv[b].w > 0.5f);
      mirrored += mirror;
      const Vec expect = mirror ? Vec{2.0 * bv[b].x - svw.x / sw, 2.0 * bv[b].y - svw.y / sw, 2.0 * bv[b].z - svw.z / sw}
                                : Vec{bv[b].x, bv[b].y, bv[b].z};
      const double err = norm3(got[b].x - expect.x, got[b].y - expect.y, got[b].z - expect.z);
      // float sums of the fluid's velocities: 1e-5 of the largest magnitude involved
      const double tol = 1e-5 * (vmax + norm3(bv[b].x, bv[b].y, bv[b].z)) + 1e-12;
      if (!(err <= tol) || got[b].w != bv[b].w)
        fb.add([&](auto& o) { o << "boundary particle " << b << ": device (" << got[b].x << ", " << got[b].y << ", " << got[b].z << ", w " << got[b].w << "), reference (" << expect.x << ", " << expect.y << ", " << expect.z << ", w " << bv[b].w << ")"; });
    }
    CHECK_NO_FAILURES(fb);
    CHECK(mirrored > 10u);  // the check saw mirrored particles, not only copies
  }
}
