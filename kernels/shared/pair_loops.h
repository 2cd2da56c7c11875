/* Neighbour-list loops of the density and force passes (device side only), eight candidates per
 * iteration in float8 vectors, then the remainder one by one (session 46 tried the remainder as one more
 * group padded with the particle itself, and did not keep it: docs/dfsph.md). The pair passes that gather
 * (not the list build and compaction) first take sixteen at a time in float16 vectors and add each half
 * of the sixteen terms to the eight-wide sums in turn: the same operations in the same order as eight at
 * a time, so the same bits; with AVX-512 the arithmetic takes half the instructions (session 52).
 *
 * Why by hand: pocl runs a work-group's work-items in a loop on each CPU core and leaves these
 * inner loops scalar (their trip counts differ per particle, and the list compaction carries a
 * dependence), so the arithmetic is written 8-wide here: positions are gathered lane by lane and
 * split into components by a transpose of shuffles, everything after that (distances, sqrt, kernel,
 * pair terms) runs in one AVX instruction per eight pairs. On a GPU the vector code is simply unrolled.
 * The eight partial sums are reduced in a fixed order, so results stay bitwise reproducible.
 *
 * The formulas are those of shared/sph_kernel.h (kernels) and of the stage files (pair terms);
 * the tests compare every pass with a brute-force reference. */
#ifndef SPHAPTICS_PAIR_LOOPS_H
#define SPHAPTICS_PAIR_LOOPS_H
#ifdef __OPENCL_VERSION__

/* The pair-loop helpers that kernels call with per-particle set-up (constants, the list): inlined by
 * force. pocl left them as calls, and each call spilled its ~10 loop constants to the stack once per
 * particle: the pressure passes ran ~10 % faster inlined (session 46, docs/dfsph.md). */
#define SPH_HOT inline __attribute__((always_inline))

/* ---- kernels for eight distances at once ---------------------------------------------------- */
inline float8 sph_w8(const float8 r, const float H) {
  const float inv_h = 1.0f / H;
  const float8 q = r * inv_h;
  const float8 t = fmax(1.0f - q, 0.0f);
#if SPH_KERNEL == SPH_KERNEL_WENDLAND_C2
  const float s = 21.0f / (2.0f * SPH_PI_F) * inv_h * inv_h * inv_h;
  return s * t * t * t * t * (1.0f + 4.0f * q);
#else
  const float s = 8.0f / SPH_PI_F * inv_h * inv_h * inv_h;
  const float8 inner = 6.0f * q * q * q - 6.0f * q * q + 1.0f;
  const float8 outer = 2.0f * t * t * t;
  return s * select(outer, inner, q <= 0.5f);
#endif
}

inline float8 sph_grad_factor8(const float8 r, const float H) {
  const float inv_h = 1.0f / H;
  const float8 q = r * inv_h;
  const float8 t = fmax(1.0f - q, 0.0f);
#if SPH_KERNEL == SPH_KERNEL_WENDLAND_C2
  const float s = 21.0f / (2.0f * SPH_PI_F) * inv_h * inv_h * inv_h;
  return -20.0f * s * t * t * t * (inv_h * inv_h);
#else
  const float s = 8.0f / SPH_PI_F * inv_h * inv_h * inv_h;
  const float8 inner = 18.0f * q - 12.0f;
  const float8 outer = -6.0f * t * t / fmax(q, 0.25f);
  return s * select(outer, inner, q <= 0.5f) * (inv_h * inv_h);
#endif
}


/* SPH_PAIR16 0 (a build option) leaves the sixteen-wide loops out: the eight-wide loops then take every group
 * (the kernel test that holds the two bitwise equal builds both). */
#ifndef SPH_PAIR16
#define SPH_PAIR16 1
#endif

/* ---- sixteen at a time (the solves' pair passes) -----------------------------------------------
 * Macros rather than functions: a function taking or returning a float16 makes clang warn on a CPU
 * without AVX-512 that the vector's calling convention differs, and pocl prints such warnings to the
 * user's stderr (session 46). Without AVX-512 the compiler splits each float16 operation in two.
 * Each writes sph_grad_factor8's or sph_w8's expressions, statement for statement, so that the values
 * are bitwise theirs (q = r / h is its own statement there too: no contraction into 1 - q).
 * SPH_Q16_OPEN(R, H): the statements they share, inv_h_, q_, t_ = max(1 - q, 0) and the kernel's
 * normalisation s_ (sph_kernel.h). */
#if SPH_KERNEL == SPH_KERNEL_WENDLAND_C2
#define SPH_S16_NORM 21.0f / (2.0f * SPH_PI_F)
#else
#define SPH_S16_NORM 8.0f / SPH_PI_F
#endif
#define SPH_Q16_OPEN(R, H)                                                                        \
  const float inv_h_ = 1.0f / (H);                                                                \
  const float16 q_ = (R) * inv_h_;                                                                \
  const float16 t_ = fmax(1.0f - q_, 0.0f);                                                       \
  const float s_ = SPH_S16_NORM * inv_h_ * inv_h_ * inv_h_

/* SPH_GRAD_FACTOR16(OUT, R, H): sph_grad_factor8's formula on sixteen distances. */
#if SPH_KERNEL == SPH_KERNEL_WENDLAND_C2
#define SPH_GRAD_FACTOR16(OUT, R, H)                                                              \
  float16 OUT;                                                                                    \
  {                                                                                               \
    SPH_Q16_OPEN(R, H);                                                                           \
    OUT = -20.0f * s_ * t_ * t_ * t_ * (inv_h_ * inv_h_);                                         \
  }
#else
#define SPH_GRAD_FACTOR16(OUT, R, H)                                                              \
  float16 OUT;                                                                                    \
  {                                                                                               \
    SPH_Q16_OPEN(R, H);                                                                           \
    OUT = s_ * select(-6.0f * t_ * t_ / fmax(q_, 0.25f), 18.0f * q_ - 12.0f, q_ <= 0.5f) * (inv_h_ * inv_h_); \
  }
#endif

/* SPH_W16(OUT, R, H): sph_w8's formula on sixteen distances (the same expressions: the same values). */
#if SPH_KERNEL == SPH_KERNEL_WENDLAND_C2
#define SPH_W16(OUT, R, H)                                                                        \
  float16 OUT;                                                                                    \
  {                                                                                               \
    SPH_Q16_OPEN(R, H);                                                                           \
    OUT = s_ * t_ * t_ * t_ * t_ * (1.0f + 4.0f * q_);                                            \
  }
#else
#define SPH_W16(OUT, R, H)                                                                        \
  float16 OUT;                                                                                    \
  {                                                                                               \
    SPH_Q16_OPEN(R, H);                                                                           \
    const float16 inner_ = 6.0f * q_ * q_ * q_ - 6.0f * q_ * q_ + 1.0f;                           \
    const float16 outer_ = 2.0f * t_ * t_ * t_;                                                   \
    OUT = s_ * select(outer_, inner_, q_ <= 0.5f);                                                \
  }
#endif

/* SPH_LOAD16(NAME, ARR, J): the sixteen float4 ARR[J.s0..sf], and their components as float16
 * NAME##_x, _y, _z, _w (lane l from J's lane l). With clang the same transpose as SPH_LANES8's, on
 * four float16 (p0|p4|p8|p12, p1|p5|p9|p13, ...): 24 shuffles for all four components. */
#define SPH_LOAD16_RAW(NAME, ARR, J)                                                              \
  const float4 NAME##0 = ARR[J.s0], NAME##1 = ARR[J.s1], NAME##2 = ARR[J.s2], NAME##3 = ARR[J.s3];     \
  const float4 NAME##4 = ARR[J.s4], NAME##5 = ARR[J.s5], NAME##6 = ARR[J.s6], NAME##7 = ARR[J.s7];     \
  const float4 NAME##8 = ARR[J.s8], NAME##9 = ARR[J.s9], NAME##10 = ARR[J.sa], NAME##11 = ARR[J.sb];   \
  const float4 NAME##12 = ARR[J.sc], NAME##13 = ARR[J.sd], NAME##14 = ARR[J.se], NAME##15 = ARR[J.sf]
#ifdef __clang__
#define SPH_Q16(P, A, B, C, D)                                                                     \
  __builtin_shufflevector(__builtin_shufflevector(P##A, P##B, 0, 1, 2, 3, 4, 5, 6, 7),              \
                          __builtin_shufflevector(P##C, P##D, 0, 1, 2, 3, 4, 5, 6, 7), 0, 1, 2, 3, 4, 5, \
                          6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
/* lo: lanes (a.x, b.x, a.y, b.y) of each 128-bit quarter; hi: (a.z, b.z, a.w, b.w) */
#define SPH_UNPACK_LO16(A, B) \
  __builtin_shufflevector(A, B, 0, 16, 1, 17, 4, 20, 5, 21, 8, 24, 9, 25, 12, 28, 13, 29)
#define SPH_UNPACK_HI16(A, B) \
  __builtin_shufflevector(A, B, 2, 18, 3, 19, 6, 22, 7, 23, 10, 26, 11, 27, 14, 30, 15, 31)
/* first (x or z) or second (y or w) pair of each quarter of two unpacked vectors */
#define SPH_PICK_FIRST16(S, T) \
  __builtin_shufflevector(S, T, 0, 1, 16, 17, 4, 5, 20, 21, 8, 9, 24, 25, 12, 13, 28, 29)
#define SPH_PICK_SECOND16(S, T) \
  __builtin_shufflevector(S, T, 2, 3, 18, 19, 6, 7, 22, 23, 10, 11, 26, 27, 14, 15, 30, 31)
#define SPH_LOAD16(NAME, ARR, J)                                                                   \
  SPH_LOAD16_RAW(NAME, ARR, J);                                                                    \
  const float16 NAME##_q0 = SPH_Q16(NAME, 0, 4, 8, 12), NAME##_q1 = SPH_Q16(NAME, 1, 5, 9, 13);    \
  const float16 NAME##_q2 = SPH_Q16(NAME, 2, 6, 10, 14), NAME##_q3 = SPH_Q16(NAME, 3, 7, 11, 15);  \
  const float16 NAME##_lo01 = SPH_UNPACK_LO16(NAME##_q0, NAME##_q1), NAME##_lo23 = SPH_UNPACK_LO16(NAME##_q2, NAME##_q3); \
  const float16 NAME##_hi01 = SPH_UNPACK_HI16(NAME##_q0, NAME##_q1), NAME##_hi23 = SPH_UNPACK_HI16(NAME##_q2, NAME##_q3); \
  const float16 NAME##_x = SPH_PICK_FIRST16(NAME##_lo01, NAME##_lo23);                            \
  const float16 NAME##_y = SPH_PICK_SECOND16(NAME##_lo01, NAME##_lo23);                           \
  const float16 NAME##_z = SPH_PICK_FIRST16(NAME##_hi01, NAME##_hi23);                            \
  const float16 NAME##_w = SPH_PICK_SECOND16(NAME##_hi01, NAME##_hi23)
#else
#define SPH_LANES16(P, C)                                                                          \
  ((float16)((P##0).C, (P##1).C, (P##2).C, (P##3).C, (P##4).C, (P##5).C, (P##6).C, (P##7).C,       \
             (P##8).C, (P##9).C, (P##10).C, (P##11).C, (P##12).C, (P##13).C, (P##14).C, (P##15).C))
#define SPH_LOAD16(NAME, ARR, J)                                                                   \
  SPH_LOAD16_RAW(NAME, ARR, J);                                                                    \
  const float16 NAME##_x = SPH_LANES16(NAME, x), NAME##_y = SPH_LANES16(NAME, y);                  \
  const float16 NAME##_z = SPH_LANES16(NAME, z), NAME##_w = SPH_LANES16(NAME, w)
#endif

/* Lane-wise gathers of sixteen (the sixteen-wide loops). */
#define SPH_GATHER16_AS(T, A, J)                                                                   \
  ((T)(A[J.s0], A[J.s1], A[J.s2], A[J.s3], A[J.s4], A[J.s5], A[J.s6], A[J.s7], A[J.s8], A[J.s9], A[J.sa], \
       A[J.sb], A[J.sc], A[J.sd], A[J.se], A[J.sf]))
#define SPH_GATHER16(A, J) SPH_GATHER16_AS(float16, A, J)

/* Lane-wise gathers. */
#define SPH_GATHER8(A, J) ((float8)(A[J.s0], A[J.s1], A[J.s2], A[J.s3], A[J.s4], A[J.s5], A[J.s6], A[J.s7]))
/* One component of eight float4 as a float8 (lane l from P##l). With clang (pocl, and the GPU
 * compilers built on it) as a 4 x 8 transpose of shuffles: the float4 are paired into four float8
 * (p0|p4, p1|p5, p2|p6, p3|p7), interleaved within each 128-bit half, and the halves' pairs picked:
 * twelve shuffles for all four components, which the compiler shares between the components a loop
 * reads (performance: written lane by lane, pocl's LLVM built each component from inserts and blends,
 * ~22 instructions per array; the values are the same either way, only moved). */
#ifdef __clang__
#define SPH_T8_AB(P) __builtin_shufflevector((P##0), (P##4), 0, 1, 2, 3, 4, 5, 6, 7), \
                     __builtin_shufflevector((P##1), (P##5), 0, 1, 2, 3, 4, 5, 6, 7)
#define SPH_T8_CD(P) __builtin_shufflevector((P##2), (P##6), 0, 1, 2, 3, 4, 5, 6, 7), \
                     __builtin_shufflevector((P##3), (P##7), 0, 1, 2, 3, 4, 5, 6, 7)
/* lo: lanes (a.x, b.x, a.y, b.y) of each half; hi: (a.z, b.z, a.w, b.w) */
inline float8 sph_unpack_lo8(const float8 a, const float8 b) {
  return __builtin_shufflevector(a, b, 0, 8, 1, 9, 4, 12, 5, 13);
}
inline float8 sph_unpack_hi8(const float8 a, const float8 b) {
  return __builtin_shufflevector(a, b, 2, 10, 3, 11, 6, 14, 7, 15);
}
/* first (x or z) or second (y or w) pair of each half of two unpacked vectors */
inline float8 sph_pick_first8(const float8 s, const float8 t) {
  return __builtin_shufflevector(s, t, 0, 1, 8, 9, 4, 5, 12, 13);
}
inline float8 sph_pick_second8(const float8 s, const float8 t) {
  return __builtin_shufflevector(s, t, 2, 3, 10, 11, 6, 7, 14, 15);
}
#define SPH_LANES8_x(P) sph_pick_first8(sph_unpack_lo8(SPH_T8_AB(P)), sph_unpack_lo8(SPH_T8_CD(P)))
#define SPH_LANES8_y(P) sph_pick_second8(sph_unpack_lo8(SPH_T8_AB(P)), sph_unpack_lo8(SPH_T8_CD(P)))
#define SPH_LANES8_z(P) sph_pick_first8(sph_unpack_hi8(SPH_T8_AB(P)), sph_unpack_hi8(SPH_T8_CD(P)))
#define SPH_LANES8_w(P) sph_pick_second8(sph_unpack_hi8(SPH_T8_AB(P)), sph_unpack_hi8(SPH_T8_CD(P)))
#define SPH_LANES8(P, C) SPH_LANES8_##C(P)
#else
#define SPH_LANES8(P, C) \
  ((float8)((P##0).C, (P##1).C, (P##2).C, (P##3).C, (P##4).C, (P##5).C, (P##6).C, (P##7).C))
#endif
#define SPH_LOAD8(NAME, ARR, J)                                                          \
  const float4 NAME##0 = ARR[J.s0], NAME##1 = ARR[J.s1], NAME##2 = ARR[J.s2], NAME##3 = ARR[J.s3]; \
  const float4 NAME##4 = ARR[J.s4], NAME##5 = ARR[J.s5], NAME##6 = ARR[J.s6], NAME##7 = ARR[J.s7]

/* Appends the lanes of J whose IN is 1 to OUT at N, in lane order: every lane is stored and N
 * advances only for those inside, so there is no data-dependent branch. */
#define SPH_APPEND8(OUT, N, J, IN)  \
  do {                              \
    OUT[N] = J.s0; N += IN.s0;      \
    OUT[N] = J.s1; N += IN.s1;      \
    OUT[N] = J.s2; N += IN.s2;      \
    OUT[N] = J.s3; N += IN.s3;      \
    OUT[N] = J.s4; N += IN.s4;      \
    OUT[N] = J.s5; N += IN.s5;      \
    OUT[N] = J.s6; N += IN.s6;      \
    OUT[N] = J.s7; N += IN.s7;      \
  } while (0)

inline float sph_hsum8(const float8 a) {
  return ((a.s0 + a.s1) + (a.s2 + a.s3)) + ((a.s4 + a.s5) + (a.s6 + a.s7));
}

/* ---- density ---------------------------------------------------------------------------------
 * sum_k w_k W(|x - x_k|) over a Verlet list, w_k = pts[k].w when `weighted` (the boundary's
 * V_b / V0) else 1. The candidates within H are appended to `out` in list order and counted in
 * *out_n: every candidate is stored and the count advances only for those inside, so the loop has
 * no data-dependent branch; a narrow fluid list (shared/neighbours.h) goes to `outs` instead, in the
 * same form. With out = outs = 0 the list is this step's list already (DFSPH's lists
 * built at H, core/simulation.cpp buildGrid): only the sum (and *out_n is not the count). */
SPH_HOT float sph_list_density(const float3 xi, __global const uint* lists, const uint i, const uint K,
                               const int wide, const uint n, __global const float4* pts,
                               const int weighted, const float H, __global uint* out, __global short* outs,
                               uint* out_n) {
  const SphList list = sph_list_k(lists, i, K, wide); /* made here, not passed in by value */
  const float H2 = H * H;
  float8 acc = (float8)(0.0f);
  uint m = 0;
  uint k = 0;
  for (; k + 8 <= n; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(p, pts, j);
    const float8 dx = xi.x - SPH_LANES8(p, x), dy = xi.y - SPH_LANES8(p, y), dz = xi.z - SPH_LANES8(p, z);
    const float8 r2 = dx * dx + dy * dy + dz * dz;
    float8 w = sph_w8(sqrt(r2), H);
    if (weighted) w *= SPH_LANES8(p, w);
    acc += w;
    const int8 in = -(r2 < H2); /* 1 inside, 0 outside */
    if (outs) {
      const short8 o = SPH_NARROW_OFFSET8(j, list.i);
      SPH_APPEND8(outs, m, o, in);
    } else if (out) {
      SPH_APPEND8(out, m, j, in);
    }
  }
  float sum = sph_hsum8(acc);
  for (; k < n; ++k) {
    const uint j = sph_list1(list, k);
    const float4 pj = pts[j];
    const float3 d = xi - pj.xyz;
    const float r2 = dot(d, d);
    sum += (weighted ? pj.w : 1.0f) * sph_w(SPH_KERNEL, sqrt(r2), H);
    if (outs) outs[m] = (short)((int)j - list.i);
    else if (out) out[m] = j;
    m += r2 < H2;
  }
  *out_n = m;
  return sum;
}

/* ---- neighbour-list build -------------------------------------------------------------------
 * Appends to out[0..K) every particle k in [begin, end) (a row of sorted particles) with
 * |x - x_k|^2 < R2, except `self`, in order; returns the new count, which goes on past K when the
 * list overflows (the caller reports it; only the first K are kept). The stores are unconditional
 * below K: a slot written for a candidate outside R is overwritten by the next one inside.
 * With `outs` (a narrow fluid list, shared/neighbours.h) the entries go there as offsets k - base
 * (base = the particle's own index; the caller checks that they fit) instead of to `out`. */
/* The two 16-float loads below return float16, which clang flags on a CPU without AVX-512 ("AVX vector
 * return of type 'float16' without 'avx512f' enabled changes the ABI"): harmless here (the function is
 * compiled into one program and inlined), but pocl printed "2 warnings generated." to the user's stderr
 * at every kernel build. Four 8-float loads instead avoid it but made the list build ~7 % slower on
 * such a CPU (session 46), so the warning is silenced for this function only. */
#ifdef __clang__
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Wpsabi"
#endif
SPH_HOT uint sph_collect_row(const float3 xi, __global const float4* pts, const uint begin, const uint end,
                             const float R2, const uint self, __global uint* out, __global short* outs,
                             const int base, const uint K, uint count) {
  uint k = begin;
  for (; k + 8 <= end; k += 8) {
    const uint8 j = (uint8)(k) + (uint8)(0, 1, 2, 3, 4, 5, 6, 7);
    /* the eight candidates are contiguous: two 16-float loads, split into x, y, z lanes by shuffles
     * (performance: eight indexed float4 loads and their transposition cost more) */
    const float16 lo = vload16(0, (__global const float*)(pts + k)), hi = vload16(0, (__global const float*)(pts + k + 4));
    const float8 px = (float8)(lo.s048c, hi.s048c), py = (float8)(lo.s159d, hi.s159d), pz = (float8)(lo.s26ae, hi.s26ae);
    const float8 dx = xi.x - px, dy = xi.y - py, dz = xi.z - pz;
    const int8 in = -((dx * dx + dy * dy + dz * dz < R2) & (j != (uint8)(self))); /* 1 inside, 0 outside */
    if (count + 8 <= K) { /* room for all eight: no per-lane check */
      if (outs) {
        const short8 o = SPH_NARROW_OFFSET8(j, base);
        SPH_APPEND8(outs, count, o, in);
      } else {
        SPH_APPEND8(out, count, j, in);
      }
    } else {
      const uint jl[8] = {j.s0, j.s1, j.s2, j.s3, j.s4, j.s5, j.s6, j.s7};
      const int il[8] = {in.s0, in.s1, in.s2, in.s3, in.s4, in.s5, in.s6, in.s7};
      for (int l = 0; l < 8; ++l) {
        if (count < K) {
          if (outs) outs[count] = (short)((int)jl[l] - base);
          else out[count] = jl[l];
        }
        count += (uint)il[l];
      }
    }
  }
  for (; k < end; ++k) {
    const float3 d = xi - pts[k].xyz;
    const uint in = (dot(d, d) < R2) & (k != self);
    if (count < K) {
      if (outs) outs[count] = (short)((int)k - base);
      else out[count] = k;
    }
    count += in;
  }
  return count;
}
#ifdef __clang__
#pragma clang diagnostic pop
#endif

/* ---- pressure and viscosity between fluid particles ------------------------------------------
 * Over this step's list (neighbours within H, from the density pass) of particle i:
 *   pressure (when `pressure`; Solenthaler & Pajarola 2008 eq. 6, see pressure.cl):
 *       f_i = -sum_j (p_i / delta_i^2 + p_j / delta_j^2) F_ij x_ij            (unit: N / m_i ... force)
 *   viscosity (when `viscous`; see viscosity.cl):
 *     artificial (Monaghan 1992): a_i = -sum_j m_j Pi_ij F_ij x_ij,
 *         Pi_ij = -alpha c0 h min(v_ij . x_ij, 0) / ((|x_ij|^2 + 0.01 h^2) (rho_i + rho_j) / 2)
 *     laminar (Morris et al. 1997, -DSPH_LAMINAR=1):
 *         a_i = sum_j m_j (mu_i + mu_j) F_ij |x_ij|^2 / (rho_i rho_j (|x_ij|^2 + 0.01 h^2)) v_ij
 * with grad W_ij = F_ij x_ij. `pressure` and `viscous` are constants after inlining. */
/* The laminar term's coefficient between fluid particles i and j: m_j (mu_i + mu_j) F r^2 / (rho_i rho_j
 * (r^2 + 0.01 h^2)), <= 0 (F < 0); a_i gains it times v_i - v_j (also the implicit viscosity's -k_ij,
 * kernels/viscosity.cl). The eight-wide loop below writes the same expression in float8. */
inline float sph_laminar_coefficient(const float mj, const float mui, const float muj, const float rhoi,
                                     const float rhoj, const float F, const float r2, const float eta2) {
  return mj * (mui + muj) * (F * r2) / (rhoi * rhoj * (r2 + eta2));
}

typedef struct {
  float3 f;  /* pressure force sum (unit: N) */
  float3 av; /* viscous acceleration (unit: m/s^2) */
} SphPairSums;

SPH_PSABI_QUIET
SPH_HOT SphPairSums sph_pair_sums(const SimParams* p, const uint i, __global const float4* pos,
                                  __global const float4* vel, __global const uint* phase,
                                  __global const float* density, __global const float* pterm,
                                  __global const uint* nbr, const uint n, const int pressure, const int viscous) {
  const float H = p->support;
  const float3 xi = pos[i].xyz;
  const float pi_term = pressure ? pterm[i] : 0.0f;
  const float3 vi = viscous ? vel[i].xyz : (float3)(0.0f);
  const float rhoi = viscous ? density[i] : 1.0f;
  const float mui = rhoi * p->phase_viscosity[phase[i]];
  const float eta2 = 0.01f * p->h * p->h;
  const float visc_k = -p->alpha * p->c0 * p->h; /* Pi = visc_k vx / (...) */
  const SphList list = sph_list(p, nbr, i); /* narrow or wide (shared/neighbours.h), made here */

  float8 fx = (float8)(0.0f), fy = fx, fz = fx, ax = fx, ay = fx, az = fx;
  uint k = 0;
  /* sixteen at a time first, each sum taking the two halves in turn: the eight-wide loop's operations in
   * its order, so bitwise its sums (performance: docs/dfsph.md, session 52) */
#if SPH_PAIR16
  for (; k + 16 <= n; k += 16) {
    const uint16 j = sph_list16(list, k);
    SPH_LOAD16(x, pos, j);
    const float16 dx = xi.x - x_x, dy = xi.y - x_y, dz = xi.z - x_z;
    const float16 r2 = dx * dx + dy * dy + dz * dz;
    SPH_GRAD_FACTOR16(F, sqrt(r2), H);
    if (pressure) {
      const float16 c = (pi_term + SPH_GATHER16(pterm, j)) * F;
      fx -= c.lo * dx.lo;
      fy -= c.lo * dy.lo;
      fz -= c.lo * dz.lo;
      fx -= c.hi * dx.hi;
      fy -= c.hi * dy.hi;
      fz -= c.hi * dz.hi;
    }
    if (viscous) {
      SPH_LOAD16(v, vel, j);
      const float16 vx = vi.x - v_x, vy = vi.y - v_y, vz = vi.z - v_z;
      const float16 rhoj = SPH_GATHER16(density, j);
      const uint16 phj = SPH_GATHER16_AS(uint16, phase, j);
      const float16 mj = SPH_GATHER16(p->phase_mass, phj);
#if SPH_LAMINAR
      const float16 muj = rhoj * SPH_GATHER16(p->phase_viscosity, phj);
      const float16 c = mj * (mui + muj) * (F * r2) / (rhoi * rhoj * (r2 + eta2));
      ax += c.lo * vx.lo;
      ay += c.lo * vy.lo;
      az += c.lo * vz.lo;
      ax += c.hi * vx.hi;
      ay += c.hi * vy.hi;
      az += c.hi * vz.hi;
#else
      const float16 vdotx = fmin(vx * dx + vy * dy + vz * dz, 0.0f);
      const float16 Pi = visc_k * vdotx / ((r2 + eta2) * (0.5f * (rhoi + rhoj)));
      const float16 c = -mj * Pi * F;
      ax += c.lo * dx.lo;
      ay += c.lo * dy.lo;
      az += c.lo * dz.lo;
      ax += c.hi * dx.hi;
      ay += c.hi * dy.hi;
      az += c.hi * dz.hi;
#endif
    }
  }
#endif
  for (; k + 8 <= n; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(x, pos, j);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    const float8 r2 = dx * dx + dy * dy + dz * dz;
    const float8 F = sph_grad_factor8(sqrt(r2), H);
    if (pressure) {
      const float8 c = (pi_term + SPH_GATHER8(pterm, j)) * F;
      fx -= c * dx;
      fy -= c * dy;
      fz -= c * dz;
    }
    if (viscous) {
      SPH_LOAD8(v, vel, j);
      const float8 vx = vi.x - SPH_LANES8(v, x), vy = vi.y - SPH_LANES8(v, y), vz = vi.z - SPH_LANES8(v, z);
      const float8 rhoj = SPH_GATHER8(density, j);
      const uint8 phj = (uint8)(phase[j.s0], phase[j.s1], phase[j.s2], phase[j.s3], phase[j.s4], phase[j.s5],
                                phase[j.s6], phase[j.s7]);
      const float8 mj = SPH_GATHER8(p->phase_mass, phj);
#if SPH_LAMINAR
      const float8 muj = rhoj * SPH_GATHER8(p->phase_viscosity, phj);
      const float8 c = mj * (mui + muj) * (F * r2) / (rhoi * rhoj * (r2 + eta2));
      ax += c * vx;
      ay += c * vy;
      az += c * vz;
#else
      const float8 vdotx = fmin(vx * dx + vy * dy + vz * dz, 0.0f);
      const float8 Pi = visc_k * vdotx / ((r2 + eta2) * (0.5f * (rhoi + rhoj)));
      const float8 c = -mj * Pi * F;
      ax += c * dx;
      ay += c * dy;
      az += c * dz;
#endif
    }
  }
  SphPairSums s;
  s.f = (float3)(sph_hsum8(fx), sph_hsum8(fy), sph_hsum8(fz));
  s.av = (float3)(sph_hsum8(ax), sph_hsum8(ay), sph_hsum8(az));
  for (; k < n; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    const float r2 = dot(d, d);
    const float F = sph_grad_factor(SPH_KERNEL, sqrt(r2), H);
    if (pressure) s.f -= (pi_term + pterm[j]) * F * d;
    if (viscous) {
      const float3 vij = vi - vel[j].xyz;
      const float rhoj = density[j];
      const uint phj = phase[j];
      const float mj = p->phase_mass[phj];
#if SPH_LAMINAR
      const float muj = rhoj * p->phase_viscosity[phj];
      s.av += sph_laminar_coefficient(mj, mui, muj, rhoi, rhoj, F, r2, eta2) * vij;
#else
      const float Pi = visc_k * fmin(dot(vij, d), 0.0f) / ((r2 + eta2) * (0.5f * (rhoi + rhoj)));
      s.av += -mj * Pi * F * d;
#endif
    }
  }
  return s;
}
SPH_PSABI_LOUD

/* Viscous acceleration of a fluid particle (mass m, density rho, kinematic viscosity nu) from
 * one boundary particle of volume ratio w = V_b / V0 at offset d = x_i - x_b (|d|^2 = r2), relative
 * velocity v = v_i - v_b, gradient factor F: the fluid pair terms above with the
 * boundary particle as a fluid particle of mass w m and the same density and viscosity. */
/* The laminar term's coefficient between a fluid particle (mass m, density rho, kinematic viscosity nu)
 * and a boundary particle of volume ratio w: (2 w m nu / rho) F r^2 / (r^2 + 0.01 h^2), <= 0 (F < 0); the
 * acceleration is it times v_i - v_b (also the implicit viscosity's -k_ib, kernels/viscosity.cl). */
inline float sph_boundary_laminar(const SimParams* p, const float m, const float rho, const float nu, const float r2,
                                  const float F, const float w) {
  return (2.0f * w * m * nu / rho) * (F * r2) / (r2 + 0.01f * p->h * p->h);
}

inline float3 sph_boundary_viscosity(const SimParams* p, const float m, const float rho, const float nu,
                                     const float3 v, const float3 d, const float r2, const float F, const float w,
                                     const float4 vb) {
  const float eta2 = 0.01f * p->h * p->h;
  /* A moving body's particle (vb.w = 1, rigid.cl) with fluid.body_viscosity physical: the laminar
   * term with the liquid's own viscosity nu, whatever the fluid's model (Akinci et al. 2012 eq. 11
   * gives the fluid-body term its own coefficient). The artificial alpha is a numerical viscosity,
   * nu_eff ~ alpha h c0 / 10 (Monaghan 2005), ~1000x water's at dx = 1 cm: on a body it is the drag
   * and squeeze film of syrup (docs/forces.md). */
  if (p->body_viscosity && vb.w > 0.5f) return sph_boundary_laminar(p, m, rho, nu, r2, F, w) * v;
#if SPH_LAMINAR
  return sph_boundary_laminar(p, m, rho, nu, r2, F, w) * v; /* (mu_i + mu_b) / (rho_i rho_b) = 2 nu / rho */
#else
  const float Pi = -p->alpha * p->c0 * p->h * fmin(dot(v, d), 0.0f) / ((r2 + eta2) * rho);
  return -w * m * Pi * F * d;
#endif
}

/* Boundary contact: acceleration of a fluid particle at offset d = x_i - x_b (|d| = r) from one
 * boundary particle of volume ratio w = V_b / V0, a short-range linear repulsion (pressure.cl's
 * header; in the spirit of Monaghan & Kajtar 2009):
 *     a = w k_c c0^2 / dx (1 - r / r0) d / r   for r < r0,   k_c = 5
 * r0 = dx at walls and cloth nodes: their lattice's gaps (a point on the wall plane is at most
 * 0.87 dx from a boundary particle) must be covered, and the force is zero at the rest spacing dx.
 * r0 = dx / 2 at a moving rigid body's particle (body = bvel.w > 0.5, rigid.cl), issue 15: a
 * body's single sampled layer on a curved surface puts the first fluid layer at 0.5-1 dx from its
 * nearest body particles, so with r0 = dx the repulsion acted on the flow past every moving body:
 * a corrugated one-sided potential that the fluid slid over, a drag of ~2 N s/m that did not
 * depend on viscosity (a 6 cm ball sinking in water: mean C_d 3.9 against a sphere's 0.4-0.5;
 * 1.2 without this term, 1.3 with r0 = 0.75 dx, and bitwise the same as without it with r0 = dx/2:
 * no fluid particle came within dx/2 of the ball). Inside dx/2 it still stops a splash particle
 * (p = 0) before it reaches the body's surface; its stiffness there, 2 k_c c0^2 / dx^2, keeps
 * dt^2 k < 2 at the CFL step (symplectic Euler needs < 4). */
inline float3 sph_boundary_contact(const SimParams* p, const float3 d, const float r, const float w, const int body) {
  const float dx = cbrt(p->rest_volume);
  const float r0 = body ? 0.5f * dx : dx;
  if (!(r < r0 && r > 1e-6f * dx)) return (float3)(0.0f);
  return w * (5.0f * p->c0 * p->c0 / dx) * (1.0f - r / r0) / r * d;
}

/* DFSPH's fictitious and added masses give their momentum back to the fluid (rigid.cl (4c), a body's;
 * dfsph.cl, dfsph_node_added_mass_reaction, a cloth node's): fluid particle i's velocity change
 * sum over its boundary neighbours b within H whose source index k is in [first, first + count) of
 * psi_b W_ib share[map ? map[k - first] : k - first] (share: a momentum over its s = sum psi_b m_i W_ib,
 * unit: m^4/s). Slot s of bpos holds boundary particle sorted[s]; this step's lists (sbnbr). */
inline float3 sph_boundary_share_dv(const SimParams* p, const uint i, __global const float4* pos,
                                    __global const float4* bpos, __global const uint* sbnbr,
                                    __global const uint* sbnbr_count, __global const uint* sorted, const uint first,
                                    const uint count, __global const uint* map, __global const float4* share) {
  const uint K = p->max_neighbours;
  const float3 xi = pos[i].xyz;
  const float H = p->support;
  const float H2 = H * H;
  float3 dv = (float3)(0.0f);
  const uint nb = sbnbr_count[i];
  for (uint q = 0; q < nb; ++q) {
    const uint s = sbnbr[(size_t)i * K + q];
    const uint k = sorted[s];
    if (k < first || k >= first + count) continue; /* another kind of boundary particle */
    const float4 pb = bpos[s];
    const float3 d = xi - pb.xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) dv += pb.w * sph_w(SPH_KERNEL, sqrt(r2), H) * share[map ? map[k - first] : k - first].xyz;
  }
  return dv;
}

/* ---- density pass: the end of it ----------------------------------------------------------------
 * From a particle's number density nd (self, fluid and boundary sums): its mass density, the equation
 * of state's pressure and p / delta^2 (density.cl, compute_density; and kernels/dfsph.cl, dfsph_factor,
 * which sums the density with the factor when the lists are this step's). Linear p = c0^2 (rho - rho0)
 * (the paper's p = k (rho - rho0) with k = c0^2), or Tait p = B ((rho / rho0)^7 - 1), B = c0^2 rho0 / 7
 * (Monaghan 1994); plus fluid.background_pressure (Morris, Fox & Zhu 1997; 0 unless the scene sets it). */
inline float sph_density_state(const SimParams* p, const uint ph, const float nd, __global float* pressure,
                               __global float* pterm, const uint i) {
  const float rho = p->phase_mass[ph] * nd;
  const float rho0 = p->phase_rest_density[ph];
  float pr;
  if (p->eos == SPH_EOS_TAIT) {
    const float ratio = rho / rho0;
    const float r2 = ratio * ratio;
    pr = p->c0 * p->c0 * rho0 / 7.0f * (r2 * r2 * r2 * ratio - 1.0f);
  } else {
    pr = p->c0 * p->c0 * (rho - rho0);
  }
  pr += p->background_pressure;
  if (p->clamp_negative_pressure) pr = fmax(pr, 0.0f);
  pressure[i] = pr;
  pterm[i] = pr / (nd * nd); /* p / delta^2, what the pressure force reads of each neighbour */
  return rho;
}

#endif
#endif
