// Fused CPU kernel: K Heun steps of spheroidal swimmers in a gridded flow
//   q(x, t_k) = sum_m c_m(t_k) I[Q_m](x)   (bilinear periodic interpolation I)
//   dx/dt = u + v_s n,  dtheta/dt = omega/2 + Lambda (S_xy cos 2theta - S_xx sin 2theta)
// Same arithmetic as swimrl.integrator.integrate_interval (the eager reference).
#include <torch/extension.h>
#include <ATen/Parallel.h>
#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

namespace {

template <typename T>
struct Eval {
  T vx, vy, w;
};

template <typename T>
inline Eval<T> rhs(const T* table, int64_t n, T inv_h, int64_t m, const T* c, int64_t f,
                   T x, T y, T th, T lam, T v) {
  const int64_t nc = m * 5;
  T sx = x * inv_h, sy = y * inv_h;
  T fx = std::floor(sx), fy = std::floor(sy);
  T a = sx - fx, b = sy - fy;
  int64_t ix0 = static_cast<int64_t>(fx) % n; if (ix0 < 0) ix0 += n;
  int64_t iy0 = static_cast<int64_t>(fy) % n; if (iy0 < 0) iy0 += n;
  int64_t ix1 = ix0 + 1 == n ? 0 : ix0 + 1;
  int64_t iy1 = iy0 + 1 == n ? 0 : iy0 + 1;
  const int64_t base = f * n * n;
  const T* r00 = table + (base + iy0 * n + ix0) * nc;
  const T* r01 = table + (base + iy0 * n + ix1) * nc;
  const T* r10 = table + (base + iy1 * n + ix0) * nc;
  const T* r11 = table + (base + iy1 * n + ix1) * nc;
  const T w00 = (1 - a) * (1 - b), w01 = a * (1 - b), w10 = (1 - a) * b, w11 = a * b;
  // bilinear blend of the M*5 contiguous channels (vectorisable), then contract with c_j
  constexpr int64_t kMaxChannels = 64;
  T blend[kMaxChannels];
  for (int64_t o = 0; o < nc; ++o) {
    blend[o] = w00 * r00[o] + w01 * r01[o] + w10 * r10[o] + w11 * r11[o];
  }
  T q[5] = {0, 0, 0, 0, 0};
  for (int64_t j = 0; j < m; ++j) {
    const T cj = c[j];
    for (int ch = 0; ch < 5; ++ch) q[ch] += cj * blend[j * 5 + ch];
  }
  const T cs = std::cos(th), sn = std::sin(th);
  const T c2 = cs * cs - sn * sn, s2 = 2 * sn * cs;
  return {q[0] + v * cs, q[1] + v * sn, T(0.5) * q[4] + lam * (q[3] * c2 - q[2] * s2)};
}

template <typename T>
void run(const torch::Tensor& table, const torch::Tensor& coeff_path,
         const torch::Tensor& flow_index, torch::Tensor& pos, torch::Tensor& theta,
         const torch::Tensor& lam, const c10::optional<torch::Tensor>& kicks, int64_t n,
         double spacing, double v_s, double dt_) {
  const int64_t P = pos.size(0), K = coeff_path.size(0) - 1, F = coeff_path.size(1),
                m = coeff_path.size(2);
  const T* tab = table.data_ptr<T>();
  const T* cp = coeff_path.data_ptr<T>();
  const int64_t* fi = flow_index.data_ptr<int64_t>();
  T* xy = pos.data_ptr<T>();
  T* th = theta.data_ptr<T>();
  const T* lm = lam.data_ptr<T>();
  const T* kk = kicks.has_value() ? kicks->data_ptr<T>() : nullptr;
  const T inv_h = T(1.0 / spacing), v = T(v_s), dt = T(dt_), hdt = T(0.5 * dt_);
  // Swimmers are advanced in blocks of kBlock in lockstep, so the table gathers of
  // independent swimmers overlap (the loop is bound by memory latency, not arithmetic).
  constexpr int64_t kBlock = 16;
  // Plain std::threads over contiguous ranges of blocks: no OpenMP runtime of our own, which
  // would compete with torch's (two spinning OpenMP pools starve each other on few cores).
  auto work = [&](int64_t b0, int64_t b1) {
    for (int64_t blk = b0; blk < b1; ++blk) {
      const int64_t p0 = blk * kBlock, nb = std::min(kBlock, P - p0);
      T x[kBlock], y[kBlock], t[kBlock], l[kBlock];
      T xp[kBlock], yp[kBlock], tp[kBlock], kick[kBlock];
      Eval<T> e1[kBlock];
      int64_t f[kBlock];
      for (int64_t i = 0; i < nb; ++i) {
        const int64_t p = p0 + i;
        x[i] = xy[2 * p]; y[i] = xy[2 * p + 1]; t[i] = th[p]; l[i] = lm[p]; f[i] = fi[p];
      }
      for (int64_t k = 0; k < K; ++k) {
        for (int64_t i = 0; i < nb; ++i) {
          e1[i] = rhs<T>(tab, n, inv_h, m, cp + (k * F + f[i]) * m, f[i], x[i], y[i], t[i], l[i], v);
          kick[i] = kk ? kk[k * P + p0 + i] : T(0);
          xp[i] = x[i] + dt * e1[i].vx;
          yp[i] = y[i] + dt * e1[i].vy;
          tp[i] = t[i] + dt * e1[i].w + kick[i];
        }
        for (int64_t i = 0; i < nb; ++i) {
          const Eval<T> e2 =
              rhs<T>(tab, n, inv_h, m, cp + ((k + 1) * F + f[i]) * m, f[i], xp[i], yp[i], tp[i], l[i], v);
          x[i] = x[i] + hdt * (e1[i].vx + e2.vx);
          y[i] = y[i] + hdt * (e1[i].vy + e2.vy);
          t[i] = t[i] + hdt * (e1[i].w + e2.w) + kick[i];
        }
      }
      for (int64_t i = 0; i < nb; ++i) {
        const int64_t p = p0 + i;
        xy[2 * p] = x[i]; xy[2 * p + 1] = y[i]; th[p] = t[i];
      }
    }
  };
  const int64_t n_blocks = (P + kBlock - 1) / kBlock;
  const int64_t n_threads =
      std::max<int64_t>(1, std::min<int64_t>(at::get_num_threads(), n_blocks / 4));
  if (n_threads == 1) {
    work(0, n_blocks);
    return;
  }
  std::vector<std::thread> pool;
  const int64_t per = (n_blocks + n_threads - 1) / n_threads;
  for (int64_t w = 0; w < n_threads; ++w) {
    const int64_t b0 = w * per, b1 = std::min(n_blocks, b0 + per);
    if (b0 < b1) pool.emplace_back(work, b0, b1);
  }
  for (auto& th_ : pool) th_.join();
}

}  // namespace

// Integrates in place: pos (P,2), theta (P,) are overwritten.
void integrate_interval_cpu(torch::Tensor table, torch::Tensor coeff_path,
                            torch::Tensor flow_index, torch::Tensor pos, torch::Tensor theta,
                            torch::Tensor lam, c10::optional<torch::Tensor> kicks, int64_t n,
                            double spacing, double swim_speed, double dt) {
  TORCH_CHECK(coeff_path.size(2) * 5 <= 64, "fused kernel supports at most 12 basis fields");
  TORCH_CHECK(table.is_contiguous() && coeff_path.is_contiguous() && pos.is_contiguous() &&
                  theta.is_contiguous() && lam.is_contiguous() && flow_index.is_contiguous(),
              "fused kernel needs contiguous tensors");
  pybind11::gil_scoped_release no_gil;
  if (table.scalar_type() == torch::kFloat64) {
    run<double>(table, coeff_path, flow_index, pos, theta, lam, kicks, n, spacing, swim_speed, dt);
  } else {
    TORCH_CHECK(table.scalar_type() == torch::kFloat32, "fused kernel: float32 or float64");
    run<float>(table, coeff_path, flow_index, pos, theta, lam, kicks, n, spacing, swim_speed, dt);
  }
}

PYBIND11_MODULE(TORCH_EXTENSION_NAME, m) {
  m.def("integrate_interval_cpu", &integrate_interval_cpu, "fused Heun swimmer kernel (CPU)");
}
