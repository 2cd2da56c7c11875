#include "core/prefix_sum.h"

#include <algorithm>

namespace sph {

void PrefixSum::run(const cl::Buffer& in, cl::Buffer& out, uint32_t n) {
  // Chunks of ~1k entries: each work-item scans one chunk serially (fast on CPUs), and the
  // serial pass over the chunk sums stays short.
  const uint32_t chunks = std::max<uint32_t>(1, (n + 1023) / 1024);
  if (chunks + 1 > capacity_) {
    capacity_ = chunks + 1;
    sums_ = clCall("allocating the prefix-sum buffer",
                   [&] { return cl::Buffer(cl_->context(), CL_MEM_READ_WRITE, capacity_ * 4); });
  }
  const uint32_t chunk = (n + chunks - 1) / chunks;
  KernelSet& k = *kernels_;
  cl::Kernel& sums = k["scan_chunk_sums"];
  sums.setArg(0, n);
  sums.setArg(1, chunk);
  sums.setArg(2, in);
  sums.setArg(3, sums_);
  k.enqueue("scan_chunk_sums", chunks);
  cl::Kernel& offs = k["scan_chunk_offsets"];
  offs.setArg(0, chunks);
  offs.setArg(1, sums_);
  k.enqueue("scan_chunk_offsets", 1);
  cl::Kernel& apply = k["scan_chunk_apply"];
  apply.setArg(0, n);
  apply.setArg(1, chunk);
  apply.setArg(2, chunks);
  apply.setArg(3, in);
  apply.setArg(4, sums_);
  apply.setArg(5, out);
  k.enqueue("scan_chunk_apply", chunks);
}

}  // namespace sph
