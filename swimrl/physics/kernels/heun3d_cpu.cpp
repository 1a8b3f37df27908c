// Fused CPU kernel: K Heun steps of 3D spheroidal swimmers in the 3D stochastic flow
// (swimrl.flows.stochastic3d: random Fourier modes evaluated at the swimmers)
//   u = sum_m w_m (P_m cos phi_m + Q_m sin phi_m),  A_ij = sum_m w_m (Q_mi cos - P_mi sin) k_mj,
//   phi_m = k_m . x,  w_m = c_{m / n_waves}(t_k)  (the terms of stochastic3d.mode_sum's table)
//   dx/dt = u + v_s n,  n turned by R(dt w),  w = omega/2 + Lambda n x (S n)
// Same arithmetic as swimrl.physics.swimmer3d.heun_step_3d (the eager reference) with the
// flow's coefficients at the step times given beforehand (coefficient path (K+1, F, M)).
//
// Layout: the swimmers are taken in runs of equal (basis row, flow); per run the row's
// wavevectors and velocity amplitudes (the table's u columns) are transposed once into a
// mode-contiguous buffer (padded to a multiple of kPad modes with zeros, which add nothing)
// and the per-mode weights of every step time are spread once; each swimmer then runs its
// K steps with the mode sum vectorised over modes (sine and cosine by a branch-free
// polynomial, #pragma omp simd: no OpenMP runtime, -fopenmp-simd only). On x86-64 with GCC
// the mode sum is compiled for x86-64-v4, -v3 and the baseline and picked at load time
// (target_clones), so one cached build serves every CPU.
#include <torch/extension.h>
#include <ATen/Parallel.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <thread>
#include <vector>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define SWIMRL_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define SWIMRL_CLONES
#endif
#if defined(__GNUC__)
#define SWIMRL_INLINE inline __attribute__((always_inline))
#else
#define SWIMRL_INLINE inline
#endif

namespace {

constexpr int64_t kPad = 16;  // modes padded to a multiple of this (a vector of floats)
constexpr int kOut = 12;      // (u_x, u_y, u_z, A_xx, A_xy, ..., A_zz)
constexpr double kPi = 3.14159265358979323846;

// sin and cos of x: x = j pi/2 + r, |r| <= pi/4 (j rounded by adding and subtracting
// 1.5 2^(digits - 1), whose low bits then hold j; r by Cody-Waite with three parts of pi/2),
// the Cephes polynomials on r, the quadrant j mod 4 by a select and a sign flip: branch-free,
// so the mode loop vectorises. Within ~1 ulp for |x| up to ~1e4 (float) / ~1e8 (double);
// the rounding needs |x| < 6e6 (float; a float phase there has no digit left after the
// point) / 2.8e15 (double).
template <typename T>
struct Trig;

template <>
struct Trig<float> {
  static SWIMRL_INLINE void sincos(float x, float& s, float& c) {
    constexpr float magic = 12582912.0f;  // 1.5 2^23
    const float tm = x * 0.636619772367581343f + magic;
    const float j = tm - magic;
    int32_t q;
    std::memcpy(&q, &tm, sizeof q);
    float r = x - j * 1.5703125f;
    r = r - j * 4.837512969970703125e-4f;
    r = r - j * 7.54978995489188216e-8f;
    const float z = r * r;
    const float ps =
        ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * r + r;
    const float pc = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z +
                      4.166664568298827e-2f) * z * z - 0.5f * z + 1.0f;
    const float s0 = (q & 1) ? pc : ps;
    const float c0 = (q & 1) ? ps : pc;
    int32_t si, ci;
    std::memcpy(&si, &s0, sizeof si);
    std::memcpy(&ci, &c0, sizeof ci);
    si ^= static_cast<int32_t>(static_cast<uint32_t>(q & 2) << 30);
    ci ^= static_cast<int32_t>(static_cast<uint32_t>((q + 1) & 2) << 30);
    std::memcpy(&s, &si, sizeof s);
    std::memcpy(&c, &ci, sizeof c);
  }
};

template <>
struct Trig<double> {
  static SWIMRL_INLINE void sincos(double x, double& s, double& c) {
    constexpr double magic = 6755399441055744.0;  // 1.5 2^52
    const double tm = x * 0.63661977236758134308 + magic;
    const double j = tm - magic;
    int64_t q;
    std::memcpy(&q, &tm, sizeof q);
    double r = x - j * 1.57079625129699707031;
    r = r - j * 7.54978941586159635336e-8;
    r = r - j * 5.39030285815811905290e-15;
    const double z = r * r;
    const double ps = r + r * z * (((((1.58962301576546568060e-10 * z -
                                       2.50507477628578072866e-8) * z +
                                      2.75573136213857245213e-6) * z -
                                     1.98412698295895385996e-4) * z +
                                    8.33333333332211858878e-3) * z -
                                   1.66666666666666307295e-1);
    const double pc = 1.0 - 0.5 * z + z * z * (((((-1.13585365213876817300e-11 * z +
                                                   2.08757008419747316778e-9) * z -
                                                  2.75573141792967388112e-7) * z +
                                                 2.48015872888517045348e-5) * z -
                                                1.38888888888730564116e-3) * z +
                                               4.16666666666665929218e-2);
    const double s0 = (q & 1) ? pc : ps;
    const double c0 = (q & 1) ? ps : pc;
    int64_t si, ci;
    std::memcpy(&si, &s0, sizeof si);
    std::memcpy(&ci, &c0, sizeof ci);
    si ^= static_cast<int64_t>(static_cast<uint64_t>(q & 2) << 62);
    ci ^= static_cast<int64_t>(static_cast<uint64_t>((q + 1) & 2) << 62);
    std::memcpy(&s, &si, sizeof s);
    std::memcpy(&c, &ci, sizeof c);
  }
};

// One basis row, modes contiguous (mp = MK padded): the wavevectors k and the velocity
// amplitudes P (the table's cos rows, columns u) and Q (its sin rows), (9, mp).
template <typename T>
struct Row {
  int64_t mp = 0;
  const T* col;
};

// (u, A) at (x, y, z) with per-mode weights w (mp,): the table's product
// [w cos, w sin] @ [[P, Q (x) k], [Q, -P (x) k]] as u = sum w (P cos + Q sin),
// A_ij = sum (w cos Q_i - w sin P_i) k_j (the same terms, fewer products).
template <typename T>
SWIMRL_INLINE void mode_sum_impl(const Row<T>& row, const T* __restrict w, T x, T y, T z,
                                 T* __restrict out) {
  const int64_t mp = row.mp;
  const T* __restrict kx = row.col;
  const T* __restrict ky = row.col + mp;
  const T* __restrict kz = row.col + 2 * mp;
  const T* __restrict p0 = row.col + 3 * mp;
  const T* __restrict p1 = row.col + 4 * mp;
  const T* __restrict p2 = row.col + 5 * mp;
  const T* __restrict q0 = row.col + 6 * mp;
  const T* __restrict q1 = row.col + 7 * mp;
  const T* __restrict q2 = row.col + 8 * mp;
  T u0 = 0, u1 = 0, u2 = 0, a00 = 0, a01 = 0, a02 = 0, a10 = 0, a11 = 0, a12 = 0, a20 = 0,
    a21 = 0, a22 = 0;
#pragma omp simd reduction(+ : u0, u1, u2, a00, a01, a02, a10, a11, a12, a20, a21, a22)
  for (int64_t m = 0; m < mp; ++m) {
    const T k0 = kx[m], k1 = ky[m], k2 = kz[m];
    const T ph = x * k0 + y * k1 + z * k2;
    T s, c;
    Trig<T>::sincos(ph, s, c);
    const T wc = c * w[m], ws = s * w[m];
    u0 += wc * p0[m];
    u0 += ws * q0[m];
    u1 += wc * p1[m];
    u1 += ws * q1[m];
    u2 += wc * p2[m];
    u2 += ws * q2[m];
    const T g0 = wc * q0[m] - ws * p0[m];
    const T g1 = wc * q1[m] - ws * p1[m];
    const T g2 = wc * q2[m] - ws * p2[m];
    a00 += g0 * k0; a01 += g0 * k1; a02 += g0 * k2;
    a10 += g1 * k0; a11 += g1 * k1; a12 += g1 * k2;
    a20 += g2 * k0; a21 += g2 * k1; a22 += g2 * k2;
  }
  out[0] = u0; out[1] = u1; out[2] = u2;
  out[3] = a00; out[4] = a01; out[5] = a02;
  out[6] = a10; out[7] = a11; out[8] = a12;
  out[9] = a20; out[10] = a21; out[11] = a22;
}

// The mode sum alone is compiled per instruction set (the rest is scalar code): a function
// of its own, so that the Heun step's live values do not crowd the loop's registers.
SWIMRL_CLONES void mode_sum_f(const Row<float>& row, const float* w, float x, float y, float z,
                              float* out) {
  mode_sum_impl<float>(row, w, x, y, z, out);
}

SWIMRL_CLONES void mode_sum_d(const Row<double>& row, const double* w, double x, double y,
                              double z, double* out) {
  mode_sum_impl<double>(row, w, x, y, z, out);
}

inline void mode_sum(const Row<float>& row, const float* w, float x, float y, float z,
                     float* out) {
  mode_sum_f(row, w, x, y, z, out);
}

inline void mode_sum(const Row<double>& row, const double* w, double x, double y, double z,
                     double* out) {
  mode_sum_d(row, w, x, y, z, out);
}

// The channels of swimmer3d.channels_from_gradient: (u, S_xx, S_yy, S_xy, S_xz, S_yz, omega).
template <typename T>
struct Channels {
  T u[3], sxx, syy, sxy, sxz, syz, om[3];
};

template <typename T>
SWIMRL_INLINE Channels<T> channels(const T* o) {
  // o = (u_x, u_y, u_z, A_00, A_01, A_02, A_10, A_11, A_12, A_20, A_21, A_22)
  const T* a = o + 3;
  const T tr = (a[0] + a[4] + a[8]) / T(3);
  Channels<T> q;
  q.u[0] = o[0]; q.u[1] = o[1]; q.u[2] = o[2];
  q.sxx = a[0] - tr;
  q.syy = a[4] - tr;
  q.sxy = T(0.5) * (a[1] + a[3]);
  q.sxz = T(0.5) * (a[2] + a[6]);
  q.syz = T(0.5) * (a[5] + a[7]);
  q.om[0] = a[7] - a[5];
  q.om[1] = a[2] - a[6];
  q.om[2] = a[3] - a[1];
  return q;
}

template <typename T>
SWIMRL_INLINE void cross(const T* a, const T* b, T* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

// swimmer3d.angular_velocity: omega/2 + Lambda n x (S n).
template <typename T>
SWIMRL_INLINE void angular_velocity(const Channels<T>& q, const T* n, T lam, T* w) {
  const T sn[3] = {q.sxx * n[0] + q.sxy * n[1] + q.sxz * n[2],
                   q.sxy * n[0] + q.syy * n[1] + q.syz * n[2],
                   q.sxz * n[0] + q.syz * n[1] - (q.sxx + q.syy) * n[2]};
  T c[3];
  cross(n, sn, c);
  for (int i = 0; i < 3; ++i) w[i] = T(0.5) * q.om[i] + lam * c[i];
}

// sinc(x) = sin(pi x) / (pi x), 1 at 0, as torch.sinc.
template <typename T>
SWIMRL_INLINE T sinc(T x) {
  if (x == T(0)) return T(1);
  const T px = T(kPi) * x;
  return std::sin(px) / px;
}

// swimmer3d.rotate: Rodrigues, n + sinc(a) phi x n + (1 - cos a)/a^2 phi x (phi x n).
template <typename T>
SWIMRL_INLINE void rotate(const T* n, const T* phi, T* out) {
  const T a = std::sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
  const T s1 = sinc<T>(a / T(kPi));
  const T h = sinc<T>(a / T(2 * kPi));
  const T s2 = T(0.5) * (h * h);
  T c[3], cc[3];
  cross(phi, n, c);
  cross(phi, c, cc);
  for (int i = 0; i < 3; ++i) out[i] = n[i] + s1 * c[i] + s2 * cc[i];
}

template <typename T>
struct Args {
  const T* k;       // (R, MK, 3)
  const T* table;   // (R, 2 MK, 12)
  const T* path;    // (K + 1, F, M)
  const int64_t* rows;   // (P,)
  const int64_t* flows;  // (P,)
  T* pos;           // (P, 3)
  T* n;             // (P, 3)
  const T* lam;     // (P,)
  const T* noise;   // (K, P, 3) or null
  int64_t P, K, F, M, MK, n_waves;
  T v, dt, hdt;
  double noise_a;   // 1 - exp(-2 D_r dt)
};

template <typename T>
SWIMRL_INLINE void swimmer(const Args<T>& g, const Row<T>& row, const T* wpath, int64_t p) {
  T x[3] = {g.pos[3 * p], g.pos[3 * p + 1], g.pos[3 * p + 2]};
  T n[3] = {g.n[3 * p], g.n[3 * p + 1], g.n[3 * p + 2]};
  const T lam = g.lam[p], v = g.v, dt = g.dt, hdt = g.hdt;
  T o[kOut];
  for (int64_t k = 0; k < g.K; ++k) {
    mode_sum(row, wpath + k * row.mp, x[0], x[1], x[2], o);
    const Channels<T> q1 = channels<T>(o);
    T v1[3], w1[3], xp[3], np[3], phi[3];
    for (int i = 0; i < 3; ++i) v1[i] = q1.u[i] + v * n[i];
    angular_velocity<T>(q1, n, lam, w1);
    for (int i = 0; i < 3; ++i) { xp[i] = x[i] + dt * v1[i]; phi[i] = dt * w1[i]; }
    rotate<T>(n, phi, np);
    mode_sum(row, wpath + (k + 1) * row.mp, xp[0], xp[1], xp[2], o);
    const Channels<T> q2 = channels<T>(o);
    T v2[3], w2[3], nn[3];
    for (int i = 0; i < 3; ++i) v2[i] = q2.u[i] + v * np[i];
    angular_velocity<T>(q2, np, lam, w2);
    for (int i = 0; i < 3; ++i) {
      x[i] = x[i] + hdt * (v1[i] + v2[i]);
      phi[i] = hdt * (w1[i] + w2[i]);
    }
    rotate<T>(n, phi, nn);
    if (g.noise) {  // swimmer3d.rotational_diffusion
      const T* xi = g.noise + (k * g.P + p) * 3;
      const T d = xi[0] * nn[0] + xi[1] * nn[1] + xi[2] * nn[2];
      T xp_[3];
      for (int i = 0; i < 3; ++i) xp_[i] = xi[i] - d * nn[i];
      const T sq = xp_[0] * xp_[0] + xp_[1] * xp_[1] + xp_[2] * xp_[2];
      const T y = std::min(T(0.5 * g.noise_a) * sq, T(2));
      const T amp = T(std::sqrt(0.5 * g.noise_a)) * std::sqrt(T(2) - y);
      for (int i = 0; i < 3; ++i) nn[i] = (T(1) - y) * nn[i] + amp * xp_[i];
    }
    const T norm = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    for (int i = 0; i < 3; ++i) n[i] = nn[i] / norm;
  }
  for (int i = 0; i < 3; ++i) { g.pos[3 * p + i] = x[i]; g.n[3 * p + i] = n[i]; }
}

// Swimmers [p0, p1): runs of equal (row, flow), each run's row and weights laid out once.
template <typename T>
void run_range(const Args<T>& g, int64_t p0, int64_t p1) {
  const int64_t mp = (g.MK + kPad - 1) / kPad * kPad;
  std::vector<T> buf(static_cast<size_t>(9 * mp), T(0));
  std::vector<T> wbuf(static_cast<size_t>((g.K + 1) * mp), T(0));
  Row<T> row;
  row.mp = mp;
  row.col = buf.data();
  int64_t cur_row = -1, cur_flow = -1;
  for (int64_t p = p0; p < p1; ++p) {
    const int64_t r = g.rows[p], f = g.flows[p];
    if (r != cur_row) {  // k, P = table[r, m, 0:3], Q = table[r, MK + m, 0:3], mode-contiguous
      const T* k = g.k + r * g.MK * 3;
      const T* tab = g.table + r * 2 * g.MK * kOut;
      T* b = buf.data();
      for (int64_t m = 0; m < g.MK; ++m) {
        for (int j = 0; j < 3; ++j) {
          b[j * mp + m] = k[3 * m + j];
          b[(3 + j) * mp + m] = tab[m * kOut + j];
          b[(6 + j) * mp + m] = tab[(g.MK + m) * kOut + j];
        }
      }
      cur_row = r;
    }
    if (f != cur_flow) {
      for (int64_t k = 0; k <= g.K; ++k) {
        const T* c = g.path + (k * g.F + f) * g.M;
        T* w = wbuf.data() + k * mp;
        for (int64_t i = 0; i < g.M; ++i) {
          std::fill(w + i * g.n_waves, w + (i + 1) * g.n_waves, c[i]);
        }
      }
      cur_flow = f;
    }
    swimmer<T>(g, row, wbuf.data(), p);
  }
}

template <typename T>
void run(const torch::Tensor& k, const torch::Tensor& table, const torch::Tensor& path,
         const torch::Tensor& rows, const torch::Tensor& flows, torch::Tensor& pos,
         torch::Tensor& n, const torch::Tensor& lam, const c10::optional<torch::Tensor>& noise,
         int64_t n_waves, double v_s, double dt, double noise_a) {
  Args<T> g;
  g.k = k.data_ptr<T>();
  g.table = table.data_ptr<T>();
  g.path = path.data_ptr<T>();
  g.rows = rows.data_ptr<int64_t>();
  g.flows = flows.data_ptr<int64_t>();
  g.pos = pos.data_ptr<T>();
  g.n = n.data_ptr<T>();
  g.lam = lam.data_ptr<T>();
  g.noise = noise.has_value() ? noise->data_ptr<T>() : nullptr;
  g.P = pos.size(0);
  g.K = path.size(0) - 1;
  g.F = path.size(1);
  g.M = path.size(2);
  g.MK = k.size(1);
  g.n_waves = n_waves;
  g.v = T(v_s);
  g.dt = T(dt);
  g.hdt = T(0.5 * dt);
  g.noise_a = noise_a;
  // Plain std::threads over contiguous ranges of swimmers (as the 2D kernel: no OpenMP
  // runtime of our own competing with torch's); a few hundred swimmers per thread at least.
  const int64_t n_threads =
      std::max<int64_t>(1, std::min<int64_t>(at::get_num_threads(), g.P / 256));
  if (n_threads == 1) {
    run_range<T>(g, 0, g.P);
    return;
  }
  std::vector<std::thread> pool;
  const int64_t per = (g.P + n_threads - 1) / n_threads;
  for (int64_t t = 0; t < n_threads; ++t) {
    const int64_t p0 = t * per, p1 = std::min(g.P, p0 + per);
    if (p0 < p1) pool.emplace_back([&g, p0, p1] { run_range<T>(g, p0, p1); });
  }
  for (auto& th : pool) th.join();
}

}  // namespace

// Integrates in place: pos (P, 3) and n (P, 3) are overwritten.
void integrate_interval_3d_cpu(torch::Tensor wavevectors, torch::Tensor table,
                               torch::Tensor coeff_path, torch::Tensor rows, torch::Tensor flows,
                               torch::Tensor pos, torch::Tensor n, torch::Tensor lam,
                               c10::optional<torch::Tensor> noise, int64_t n_waves,
                               double swim_speed, double dt, double noise_a) {
  const auto dtype = pos.scalar_type();
  TORCH_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "fused 3D kernel: float32 or float64");
  std::vector<torch::Tensor> all = {wavevectors, table, coeff_path, rows, flows, pos, n, lam};
  if (noise.has_value()) all.push_back(*noise);
  for (const auto& t : all) {
    TORCH_CHECK(t.device().is_cpu() && t.is_contiguous(),
                "fused 3D kernel needs contiguous CPU tensors");
  }
  for (const auto& t : {wavevectors, table, coeff_path, n, lam}) {
    TORCH_CHECK(t.scalar_type() == dtype, "fused 3D kernel: one dtype for all real tensors");
  }
  TORCH_CHECK(!noise.has_value() || noise->scalar_type() == dtype,
              "fused 3D kernel: one dtype for all real tensors");
  TORCH_CHECK(rows.scalar_type() == torch::kInt64 && flows.scalar_type() == torch::kInt64,
              "fused 3D kernel: int64 row and flow indices");
  const int64_t P = pos.size(0), MK = wavevectors.size(1);
  TORCH_CHECK(pos.dim() == 2 && pos.size(1) == 3 && n.sizes() == pos.sizes() && lam.numel() == P &&
                  rows.numel() == P && flows.numel() == P,
              "fused 3D kernel: pos, n (P, 3); lam, rows, flows (P,)");
  TORCH_CHECK(wavevectors.dim() == 3 && wavevectors.size(2) == 3 && table.dim() == 3 &&
                  table.size(0) == wavevectors.size(0) && table.size(1) == 2 * MK &&
                  table.size(2) == kOut,
              "fused 3D kernel: wavevectors (R, MK, 3), table (R, 2 MK, 12)");
  TORCH_CHECK(coeff_path.dim() == 3 && coeff_path.size(0) >= 1 && n_waves >= 1 &&
                  coeff_path.size(2) * n_waves == MK,
              "fused 3D kernel: coefficient path (K + 1, F, M) with M n_waves = MK");
  TORCH_CHECK(!noise.has_value() ||
                  (noise->dim() == 3 && noise->size(0) == coeff_path.size(0) - 1 &&
                   noise->size(1) == P && noise->size(2) == 3),
              "fused 3D kernel: noise (K, P, 3)");
  if (P > 0) {
    const int64_t rmax = rows.max().item<int64_t>(), rmin = rows.min().item<int64_t>();
    const int64_t fmax = flows.max().item<int64_t>(), fmin = flows.min().item<int64_t>();
    TORCH_CHECK(rmin >= 0 && rmax < wavevectors.size(0) && fmin >= 0 && fmax < coeff_path.size(1),
                "fused 3D kernel: row or flow index out of range");
  }
  pybind11::gil_scoped_release no_gil;
  if (dtype == torch::kFloat64) {
    run<double>(wavevectors, table, coeff_path, rows, flows, pos, n, lam, noise, n_waves,
                swim_speed, dt, noise_a);
  } else {
    run<float>(wavevectors, table, coeff_path, rows, flows, pos, n, lam, noise, n_waves,
               swim_speed, dt, noise_a);
  }
}

PYBIND11_MODULE(TORCH_EXTENSION_NAME, m) {
  m.def("integrate_interval_3d_cpu", &integrate_interval_3d_cpu,
        "fused Heun kernel of 3D swimmers in the 3D stochastic flow (CPU)");
}
