// Exclusive prefix sum of uint counts on the device (kernels/scan.cl), shared by the neighbour
// grid and the isosurface stage. Deterministic: integer sums in a fixed chunk order.
#pragma once

#include "core/cl_context.h"

#include <cstdint>

namespace sph {

class PrefixSum {
 public:
  PrefixSum() = default;
  /// `kernels` must outlive this object.
  PrefixSum(ClContext& cl, KernelSet& kernels) : cl_(&cl), kernels_(&kernels) {}
  /// out[i] = in[0] + ... + in[i-1] for i <= n (out has n + 1 entries; out[n] is the total).
  /// Enqueues only; the queue orders it before later commands.
  void run(const cl::Buffer& in, cl::Buffer& out, uint32_t n);
  /// Device memory held (unit: bytes).
  std::size_t bytes() const { return capacity_ * 4; }

 private:
  ClContext* cl_ = nullptr;
  KernelSet* kernels_ = nullptr;
  cl::Buffer sums_;             // one partial sum per chunk, plus the total
  std::size_t capacity_ = 0;    // entries in sums_
};

}  // namespace sph
