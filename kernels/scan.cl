/* Exclusive prefix sum of uint counts (stage: always, part of the neighbour grid).
 * Three passes, each work-item owning one contiguous chunk: chunk sums, a serial scan of the
 * chunk sums (few hundred entries), then the chunk-local scan with its offset. Writes n + 1
 * outputs: out[n] is the total. Chunked, not tree-shaped, because on the CPU (pocl) sequential
 * runs are what is fast; on a GPU it is still a small share of the step. */

__kernel void scan_chunk_sums(const uint n, const uint chunk, __global const uint* in, __global uint* sums) {
  const uint g = get_global_id(0);
  const uint begin = g * chunk;
  if (begin >= n) { sums[g] = 0; return; }
  const uint end = min(begin + chunk, n);
  uint s = 0;
  for (uint i = begin; i < end; ++i) s += in[i];
  sums[g] = s;
}

__kernel void scan_chunk_offsets(const uint num_chunks, __global uint* sums) {
  if (get_global_id(0) != 0) return;
  uint running = 0;
  for (uint g = 0; g < num_chunks; ++g) { const uint v = sums[g]; sums[g] = running; running += v; }
  sums[num_chunks] = running;
}

__kernel void scan_chunk_apply(const uint n, const uint chunk, const uint num_chunks, __global const uint* in,
                               __global const uint* sums, __global uint* out) {
  const uint g = get_global_id(0);
  const uint begin = g * chunk;
  if (begin >= n) return;
  const uint end = min(begin + chunk, n);
  uint running = sums[g];
  for (uint i = begin; i < end; ++i) { out[i] = running; running += in[i]; }
  if (end == n) out[n] = sums[num_chunks];
}
