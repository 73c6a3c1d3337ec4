// dop853.hpp -- a compact C++17 DOP853 for the ezy peer benchmarks.
//
// The explicit Runge-Kutta method of order 8 of Dormand & Prince with the
// 8(5,3) error estimate and the step-size control of Hairer's code DOP853,
// as described in
//
//   E. Hairer, S. P. Norsett, G. Wanner, Solving Ordinary Differential
//   Equations I, Nonstiff Problems, 2nd ed., Springer 1993, Sec. II.10
//   (and II.4 for the starting step size),
//
// and implemented by Hairer & Wanner in dop853.f (C translation dop853.c by
// J. Colinge; the copy read for this file is the one shipped with PyDSTool,
// github.com/robclewley/pydstool, PyDSTool/integrator/dop853.c). The
// coefficients below are Hairer's published constants; the control is his:
//
//   sk_i  = atol + rtol * max(|y_i|, |y_new_i|)
//   err5  = sum_i (e5_i / sk_i)^2      (order-5 estimator, weights er*)
//   err3  = sum_i (e3_i / sk_i)^2      (order-3 estimator, b - bhh)
//   err   = |h| err5 / sqrt(n (err5 + 0.01 err3))
//   fac11 = err^(1/8 - 0.2 beta);  fac = fac11 / facold^beta   (beta = 0)
//   fac   = clamp(fac / safe, 1/fac2, 1/fac1);  h_new = h / fac
//   accepted (err <= 1): facold = max(err, 1e-4); after a rejection
//       h_new = min(h_new, h); h_new = min(h_new, hmax)
//   rejected: h_new = h / min(1/fac1, fac11 / safe)
//
// with safe = 0.9, fac1 = 0.333, fac2 = 6, beta = 0 (Hairer's defaults),
// the starting step of his HINIT, FSAL (the 13th evaluation, at the new
// state, is the next step's first stage), and the last step cut to end at
// x_end when x + 1.01 h passes it, and his exits for too many steps and
// for a step size at the rounding level of x (return codes -2, -3). Not
// implemented: dense output (output only at x_end) and the stiffness test
// (a diagnostic that does not change the steps).
//
// This is our own code, written from the book and read against Hairer's
// code; any error in it is ours.
//
// Optional post-step hook: after every accepted step the caller may change
// y (coordinate projection, as ezy does, docs/physics.md Sec. 6). The hook
// runs before the FSAL evaluation, so the next step's first stage is
// evaluated at the projected state at no extra cost (ezy evaluates F at
// the unprojected state as its 12th stage and once more after projecting:
// one evaluation per accepted step more than here).

#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace dop853 {

struct Options {
  double rtol = 1e-6;
  double atol = 1e-6;
  double h0 = 0.0;       // 0: Hairer's HINIT
  double hmax = 0.0;     // 0: x_end - x
  long nmax = 100000000; // step attempts
  double safe = 0.9, fac1 = 0.333, fac2 = 6.0, beta = 0.0;
};

struct Stats {
  long nfcn = 0;    // right-hand-side evaluations (counted here)
  long nstep = 0;   // step attempts
  long naccpt = 0;  // accepted steps
  long nrejct = 0;  // rejected steps
};

struct NoPost {
  template <class Y> void operator()(double, Y&) const {}
};

// Hairer's constants (dop853.f / dop853.c, method 1).
namespace c {
constexpr double c2 = 0.526001519587677318785587544488e-01;
constexpr double c3 = 0.789002279381515978178381316732e-01;
constexpr double c4 = 0.118350341907227396726757197510e+00;
constexpr double c5 = 0.281649658092772603273242802490e+00;
constexpr double c6 = 0.333333333333333333333333333333e+00;
constexpr double c7 = 0.25e+00;
constexpr double c8 = 0.307692307692307692307692307692e+00;
constexpr double c9 = 0.651282051282051282051282051282e+00;
constexpr double c10 = 0.6e+00;
constexpr double c11 = 0.857142857142857142857142857142e+00;

constexpr double b1 = 5.42937341165687622380535766363e-2;
constexpr double b6 = 4.45031289275240888144113950566e0;
constexpr double b7 = 1.89151789931450038304281599044e0;
constexpr double b8 = -5.8012039600105847814672114227e0;
constexpr double b9 = 3.1116436695781989440891606237e-1;
constexpr double b10 = -1.52160949662516078556178806805e-1;
constexpr double b11 = 2.01365400804030348374776537501e-1;
constexpr double b12 = 4.47106157277725905176885569043e-2;

constexpr double bhh1 = 0.244094488188976377952755905512e+00;
constexpr double bhh2 = 0.733846688281611857341361741547e+00;
constexpr double bhh3 = 0.220588235294117647058823529412e-01;

constexpr double er1 = 0.1312004499419488073250102996e-01;
constexpr double er6 = -0.1225156446376204440720569753e+01;
constexpr double er7 = -0.4957589496572501915214079952e+00;
constexpr double er8 = 0.1664377182454986536961530415e+01;
constexpr double er9 = -0.3503288487499736816886487290e+00;
constexpr double er10 = 0.3341791187130174790297318841e+00;
constexpr double er11 = 0.8192320648511571246570742613e-01;
constexpr double er12 = -0.2235530786388629525884427845e-01;

constexpr double a21 = 5.26001519587677318785587544488e-2;
constexpr double a31 = 1.97250569845378994544595329183e-2;
constexpr double a32 = 5.91751709536136983633785987549e-2;
constexpr double a41 = 2.95875854768068491816892993775e-2;
constexpr double a43 = 8.87627564304205475450678981324e-2;
constexpr double a51 = 2.41365134159266685502369798665e-1;
constexpr double a53 = -8.84549479328286085344864962717e-1;
constexpr double a54 = 9.24834003261792003115737966543e-1;
constexpr double a61 = 3.7037037037037037037037037037e-2;
constexpr double a64 = 1.70828608729473871279604482173e-1;
constexpr double a65 = 1.25467687566822425016691814123e-1;
constexpr double a71 = 3.7109375e-2;
constexpr double a74 = 1.70252211019544039314978060272e-1;
constexpr double a75 = 6.02165389804559606850219397283e-2;
constexpr double a76 = -1.7578125e-2;
constexpr double a81 = 3.70920001185047927108779319836e-2;
constexpr double a84 = 1.70383925712239993810214054705e-1;
constexpr double a85 = 1.07262030446373284651809199168e-1;
constexpr double a86 = -1.53194377486244017527936158236e-2;
constexpr double a87 = 8.27378916381402288758473766002e-3;
constexpr double a91 = 6.24110958716075717114429577812e-1;
constexpr double a94 = -3.36089262944694129406857109825e0;
constexpr double a95 = -8.68219346841726006818189891453e-1;
constexpr double a96 = 2.75920996994467083049415600797e1;
constexpr double a97 = 2.01540675504778934086186788979e1;
constexpr double a98 = -4.34898841810699588477366255144e1;
constexpr double a101 = 4.77662536438264365890433908527e-1;
constexpr double a104 = -2.48811461997166764192642586468e0;
constexpr double a105 = -5.90290826836842996371446475743e-1;
constexpr double a106 = 2.12300514481811942347288949897e1;
constexpr double a107 = 1.52792336328824235832596922938e1;
constexpr double a108 = -3.32882109689848629194453265587e1;
constexpr double a109 = -2.03312017085086261358222928593e-2;
constexpr double a111 = -9.3714243008598732571704021658e-1;
constexpr double a114 = 5.18637242884406370830023853209e0;
constexpr double a115 = 1.09143734899672957818500254654e0;
constexpr double a116 = -8.14978701074692612513997267357e0;
constexpr double a117 = -1.85200656599969598641566180701e1;
constexpr double a118 = 2.27394870993505042818970056734e1;
constexpr double a119 = 2.49360555267965238987089396762e0;
constexpr double a1110 = -3.0467644718982195003823669022e0;
constexpr double a121 = 2.27331014751653820792359768449e0;
constexpr double a124 = -1.05344954667372501984066689879e1;
constexpr double a125 = -2.00087205822486249909675718444e0;
constexpr double a126 = -1.79589318631187989172765950534e1;
constexpr double a127 = 2.79488845294199600508499808837e1;
constexpr double a128 = -2.85899827713502369474065508674e0;
constexpr double a129 = -8.87285693353062954433549289258e0;
constexpr double a1210 = 1.23605671757943030647266201528e1;
constexpr double a1211 = 6.43392746015763530355970484046e-1;
}  // namespace c

// Hairer's HINIT: a first step such that h^8 max(|f0|, |f'|) = 0.01 in the
// weighted norm (sums of squares, as in his code), at most 100 times the
// step of an explicit Euler step with |y| / |f0| = 100.
template <std::size_t N, class F>
double hinit(F& f, double x, const std::array<double, N>& y,
             const std::array<double, N>& f0, double hmax, const Options& o,
             Stats& st) {
  double dnf = 0.0, dny = 0.0;
  for (std::size_t i = 0; i < N; ++i) {
    const double sk = o.atol + o.rtol * std::fabs(y[i]);
    dnf += (f0[i] / sk) * (f0[i] / sk);
    dny += (y[i] / sk) * (y[i] / sk);
  }
  double h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : std::sqrt(dny / dnf) * 0.01;
  h = std::min(h, hmax);
  std::array<double, N> y1, f1;
  for (std::size_t i = 0; i < N; ++i) y1[i] = y[i] + h * f0[i];
  f(x + h, y1, f1);
  ++st.nfcn;
  double der2 = 0.0;
  for (std::size_t i = 0; i < N; ++i) {
    const double sk = o.atol + o.rtol * std::fabs(y[i]);
    const double s = (f1[i] - f0[i]) / sk;
    der2 += s * s;
  }
  der2 = std::sqrt(der2) / h;
  const double der12 = std::max(std::fabs(der2), std::sqrt(dnf));
  const double h1 = der12 <= 1e-15 ? std::max(1e-6, std::fabs(h) * 1e-3)
                                   : std::pow(0.01 / der12, 1.0 / 8.0);
  return std::min(100.0 * h, std::min(h1, hmax));
}

// Integrates y' = f(x, y) from x to x_end (x_end > x), y overwritten with
// the solution at x_end. f(x, y, dy) with std::array<double, N>. post(x, y)
// is called after every accepted step (see the file comment). Returns 1 on
// success, -2 when nmax step attempts were not enough, -3 when the step
// size became too small.
template <std::size_t N, class F, class P = NoPost>
int integrate(F&& f, double x, std::array<double, N>& y, double xend,
              const Options& o, Stats& st, P&& post = P{}) {
  using namespace c;
  using V = std::array<double, N>;
  const double uround = 2.3e-16;
  const double hmax = o.hmax > 0.0 ? o.hmax : xend - x;
  const double expo1 = 1.0 / 8.0 - o.beta * 0.2;
  const double facc1 = 1.0 / o.fac1, facc2 = 1.0 / o.fac2;
  V k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, yn, s;
  f(x, y, k1);
  ++st.nfcn;
  double h = o.h0 > 0.0 ? o.h0 : hinit<N>(f, x, y, k1, hmax, o, st);
  double facold = 1e-4;
  bool reject = false, last = false;
  for (;;) {
    if (st.nstep >= o.nmax) return -2;
    if (0.1 * std::fabs(h) <= std::fabs(x) * uround) return -3;
    if (x + 1.01 * h - xend > 0.0) {
      h = xend - x;
      last = true;
    }
    ++st.nstep;
    for (std::size_t i = 0; i < N; ++i) s[i] = y[i] + h * a21 * k1[i];
    f(x + c2 * h, s, k2);
    for (std::size_t i = 0; i < N; ++i) s[i] = y[i] + h * (a31 * k1[i] + a32 * k2[i]);
    f(x + c3 * h, s, k3);
    for (std::size_t i = 0; i < N; ++i) s[i] = y[i] + h * (a41 * k1[i] + a43 * k3[i]);
    f(x + c4 * h, s, k4);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a51 * k1[i] + a53 * k3[i] + a54 * k4[i]);
    f(x + c5 * h, s, k5);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a61 * k1[i] + a64 * k4[i] + a65 * k5[i]);
    f(x + c6 * h, s, k6);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a71 * k1[i] + a74 * k4[i] + a75 * k5[i] + a76 * k6[i]);
    f(x + c7 * h, s, k7);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a81 * k1[i] + a84 * k4[i] + a85 * k5[i] + a86 * k6[i] +
                         a87 * k7[i]);
    f(x + c8 * h, s, k8);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a91 * k1[i] + a94 * k4[i] + a95 * k5[i] + a96 * k6[i] +
                         a97 * k7[i] + a98 * k8[i]);
    f(x + c9 * h, s, k9);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a101 * k1[i] + a104 * k4[i] + a105 * k5[i] + a106 * k6[i] +
                         a107 * k7[i] + a108 * k8[i] + a109 * k9[i]);
    f(x + c10 * h, s, k10);
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a111 * k1[i] + a114 * k4[i] + a115 * k5[i] + a116 * k6[i] +
                         a117 * k7[i] + a118 * k8[i] + a119 * k9[i] + a1110 * k10[i]);
    f(x + c11 * h, s, k11);
    const double xph = x + h;
    for (std::size_t i = 0; i < N; ++i)
      s[i] = y[i] + h * (a121 * k1[i] + a124 * k4[i] + a125 * k5[i] + a126 * k6[i] +
                         a127 * k7[i] + a128 * k8[i] + a129 * k9[i] +
                         a1210 * k10[i] + a1211 * k11[i]);
    f(xph, s, k12);
    st.nfcn += 11;
    // the order-8 solution and the two error estimators
    double err = 0.0, err2 = 0.0;
    for (std::size_t i = 0; i < N; ++i) {
      const double bk = b1 * k1[i] + b6 * k6[i] + b7 * k7[i] + b8 * k8[i] +
                        b9 * k9[i] + b10 * k10[i] + b11 * k11[i] + b12 * k12[i];
      yn[i] = y[i] + h * bk;
      const double sk = o.atol + o.rtol * std::max(std::fabs(y[i]), std::fabs(yn[i]));
      const double e3 = (bk - bhh1 * k1[i] - bhh2 * k9[i] - bhh3 * k12[i]) / sk;
      const double e5 = (er1 * k1[i] + er6 * k6[i] + er7 * k7[i] + er8 * k8[i] +
                         er9 * k9[i] + er10 * k10[i] + er11 * k11[i] + er12 * k12[i]) / sk;
      err2 += e3 * e3;
      err += e5 * e5;
    }
    double deno = err + 0.01 * err2;
    if (deno <= 0.0) deno = 1.0;
    err = std::fabs(h) * err * std::sqrt(1.0 / (deno * static_cast<double>(N)));
    // the new step size
    const double fac11 = std::pow(err, expo1);
    double fac = fac11 / std::pow(facold, o.beta);
    fac = std::max(facc2, std::min(facc1, fac / o.safe));
    double hnew = h / fac;
    if (err <= 1.0) {
      facold = std::max(err, 1e-4);
      ++st.naccpt;
      y = yn;
      x = xph;
      // The 13th evaluation, at the new state, is the next step's first
      // stage (FSAL). A projecting hook moves the state first, so the
      // evaluation is at the projected state and costs nothing extra.
      post(x, y);
      f(x, y, k1);
      ++st.nfcn;
      if (last) return 1;
      if (std::fabs(hnew) > hmax) hnew = hmax;
      if (reject) hnew = std::min(std::fabs(hnew), std::fabs(h));
      reject = false;
    } else {
      hnew = h / std::min(facc1, fac11 / o.safe);
      reject = true;
      if (st.naccpt >= 1) ++st.nrejct;
      last = false;
    }
    h = hnew;
  }
}

}  // namespace dop853
