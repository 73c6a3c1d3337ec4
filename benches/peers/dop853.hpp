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
// for a step size at the rounding level of x (return codes -2, -3), and
// his dense output of order 7 (CONTD8: three more stages in a step that
// holds an output time, the coefficients rcont1..8, and the polynomial
// evaluated at each output time, Options::every > 0). Not implemented: the
// stiffness test (a diagnostic that does not change the steps).
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
#include <type_traits>

namespace dop853 {

struct Options {
  double rtol = 1e-6;
  double atol = 1e-6;
  double h0 = 0.0;       // 0: Hairer's HINIT
  double hmax = 0.0;     // 0: x_end - x
  long nmax = 100000000; // step attempts
  double safe = 0.9, fac1 = 0.333, fac2 = 6.0, beta = 0.0;
  double every = 0.0;    // > 0: dense output at every multiple of it
};

struct Stats {
  long nfcn = 0;    // right-hand-side evaluations (counted here)
  long nstep = 0;   // step attempts
  long naccpt = 0;  // accepted steps
  long nrejct = 0;  // rejected steps
  long nout = 0;    // dense-output samples
  double sink = 0.0;  // the sum of every sample's components (keeps them computed)
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
// the dense output's stages 14-16 and its coefficients (CONTD8)
constexpr double c14 = 0.1e+00;
constexpr double c15 = 0.2e+00;
constexpr double c16 = 0.777777777777777777777777777778e+00;
constexpr double a141 = 5.61675022830479523392909219681e-2;
constexpr double a147 = 2.53500210216624811088794765333e-1;
constexpr double a148 = -2.46239037470802489917441475441e-1;
constexpr double a149 = -1.24191423263816360469010140626e-1;
constexpr double a1410 = 1.5329179827876569731206322685e-1;
constexpr double a1411 = 8.20105229563468988491666602057e-3;
constexpr double a1412 = 7.56789766054569976138603589584e-3;
constexpr double a1413 = -8.298e-3;
constexpr double a151 = 3.18346481635021405060768473261e-2;
constexpr double a156 = 2.83009096723667755288322961402e-2;
constexpr double a157 = 5.35419883074385676223797384372e-2;
constexpr double a158 = -5.49237485713909884646569340306e-2;
constexpr double a1511 = -1.08347328697249322858509316994e-4;
constexpr double a1512 = 3.82571090835658412954920192323e-4;
constexpr double a1513 = -3.40465008687404560802977114492e-4;
constexpr double a1514 = 1.41312443674632500278074618366e-1;
constexpr double a161 = -4.28896301583791923408573538692e-1;
constexpr double a166 = -4.69762141536116384314449447206e0;
constexpr double a167 = 7.68342119606259904184240953878e0;
constexpr double a168 = 4.06898981839711007970213554331e0;
constexpr double a169 = 3.56727187455281109270669543021e-1;
constexpr double a1613 = -1.39902416515901462129418009734e-3;
constexpr double a1614 = 2.9475147891527723389556272149e0;
constexpr double a1615 = -9.15095847217987001081870187138e0;
constexpr double d41 = -0.84289382761090128651353491142e+01;
constexpr double d46 = 0.56671495351937776962531783590e+00;
constexpr double d47 = -0.30689499459498916912797304727e+01;
constexpr double d48 = 0.23846676565120698287728149680e+01;
constexpr double d49 = 0.21170345824450282767155149946e+01;
constexpr double d410 = -0.87139158377797299206789907490e+00;
constexpr double d411 = 0.22404374302607882758541771650e+01;
constexpr double d412 = 0.63157877876946881815570249290e+00;
constexpr double d413 = -0.88990336451333310820698117400e-01;
constexpr double d414 = 0.18148505520854727256656404962e+02;
constexpr double d415 = -0.91946323924783554000451984436e+01;
constexpr double d416 = -0.44360363875948939664310572000e+01;
constexpr double d51 = 0.10427508642579134603413151009e+02;
constexpr double d56 = 0.24228349177525818288430175319e+03;
constexpr double d57 = 0.16520045171727028198505394887e+03;
constexpr double d58 = -0.37454675472269020279518312152e+03;
constexpr double d59 = -0.22113666853125306036270938578e+02;
constexpr double d510 = 0.77334326684722638389603898808e+01;
constexpr double d511 = -0.30674084731089398182061213626e+02;
constexpr double d512 = -0.93321305264302278729567221706e+01;
constexpr double d513 = 0.15697238121770843886131091075e+02;
constexpr double d514 = -0.31139403219565177677282850411e+02;
constexpr double d515 = -0.93529243588444783865713862664e+01;
constexpr double d516 = 0.35816841486394083752465898540e+02;
constexpr double d61 = 0.19985053242002433820987653617e+02;
constexpr double d66 = -0.38703730874935176555105901742e+03;
constexpr double d67 = -0.18917813819516756882830838328e+03;
constexpr double d68 = 0.52780815920542364900561016686e+03;
constexpr double d69 = -0.11573902539959630126141871134e+02;
constexpr double d610 = 0.68812326946963000169666922661e+01;
constexpr double d611 = -0.10006050966910838403183860980e+01;
constexpr double d612 = 0.77771377980534432092869265740e+00;
constexpr double d613 = -0.27782057523535084065932004339e+01;
constexpr double d614 = -0.60196695231264120758267380846e+02;
constexpr double d615 = 0.84320405506677161018159903784e+02;
constexpr double d616 = 0.11992291136182789328035130030e+02;
constexpr double d71 = -0.25693933462703749003312586129e+02;
constexpr double d76 = -0.15418974869023643374053993627e+03;
constexpr double d77 = -0.23152937917604549567536039109e+03;
constexpr double d78 = 0.35763911791061412378285349910e+03;
constexpr double d79 = 0.93405324183624310003907691704e+02;
constexpr double d710 = -0.37458323136451633156875139351e+02;
constexpr double d711 = 0.10409964950896230045147246184e+03;
constexpr double d712 = 0.29840293426660503123344363579e+02;
constexpr double d713 = -0.43533456590011143754432175058e+02;
constexpr double d714 = 0.96324553959188282948394950600e+02;
constexpr double d715 = -0.39177261675615439165231486172e+02;
constexpr double d716 = -0.14972683625798562581422125276e+03;
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
// size became too small, -4 for dense output asked with a projecting hook.
template <std::size_t N, class F, class P = NoPost>
int integrate(F&& f, double x, std::array<double, N>& y, double xend,
              const Options& o, Stats& st, P&& post = P{}) {
  using namespace c;
  using V = std::array<double, N>;
  // the dense output takes the 13th evaluation at the unprojected state:
  // a projecting hook and dense output do not go together here
  constexpr bool projects = !std::is_same_v<std::decay_t<P>, NoPost>;
  const double uround = 2.3e-16;
  const double hmax = o.hmax > 0.0 ? o.hmax : xend - x;
  const double expo1 = 1.0 / 8.0 - o.beta * 0.2;
  const double facc1 = 1.0 / o.fac1, facc2 = 1.0 / o.fac2;
  if (projects && o.every > 0.0) return -4;
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
      const bool dense = o.every > 0.0 && static_cast<double>(st.nout) * o.every <= xph;
      V k13;
      if (dense) {
        // CONTD8: the 13th evaluation at the new state first (it is the
        // next step's first stage as well), three more stages, the
        // coefficients, and the samples in (x, xph]; Hairer's order of
        // operations. (Without a projecting hook: the reduced peer.)
        V k14, k15, k16;
        f(xph, yn, k13);
        for (std::size_t i = 0; i < N; ++i)
          s[i] = y[i] + h * (a141 * k1[i] + a147 * k7[i] + a148 * k8[i] + a149 * k9[i] +
                             a1410 * k10[i] + a1411 * k11[i] + a1412 * k12[i] + a1413 * k13[i]);
        f(x + c14 * h, s, k14);
        for (std::size_t i = 0; i < N; ++i)
          s[i] = y[i] + h * (a151 * k1[i] + a156 * k6[i] + a157 * k7[i] + a158 * k8[i] +
                             a1511 * k11[i] + a1512 * k12[i] + a1513 * k13[i] + a1514 * k14[i]);
        f(x + c15 * h, s, k15);
        for (std::size_t i = 0; i < N; ++i)
          s[i] = y[i] + h * (a161 * k1[i] + a166 * k6[i] + a167 * k7[i] + a168 * k8[i] +
                             a169 * k9[i] + a1613 * k13[i] + a1614 * k14[i] + a1615 * k15[i]);
        f(x + c16 * h, s, k16);
        st.nfcn += 4;
        std::array<V, 8> r;
        for (std::size_t i = 0; i < N; ++i) {
          const double ydiff = yn[i] - y[i], bspl = h * k1[i] - ydiff;
          r[0][i] = y[i];
          r[1][i] = ydiff;
          r[2][i] = bspl;
          r[3][i] = ydiff - h * k13[i] - bspl;
          r[4][i] = h * (d41 * k1[i] + d46 * k6[i] + d47 * k7[i] + d48 * k8[i] + d49 * k9[i] +
                         d410 * k10[i] + d411 * k11[i] + d412 * k12[i] + d413 * k13[i] +
                         d414 * k14[i] + d415 * k15[i] + d416 * k16[i]);
          r[5][i] = h * (d51 * k1[i] + d56 * k6[i] + d57 * k7[i] + d58 * k8[i] + d59 * k9[i] +
                         d510 * k10[i] + d511 * k11[i] + d512 * k12[i] + d513 * k13[i] +
                         d514 * k14[i] + d515 * k15[i] + d516 * k16[i]);
          r[6][i] = h * (d61 * k1[i] + d66 * k6[i] + d67 * k7[i] + d68 * k8[i] + d69 * k9[i] +
                         d610 * k10[i] + d611 * k11[i] + d612 * k12[i] + d613 * k13[i] +
                         d614 * k14[i] + d615 * k15[i] + d616 * k16[i]);
          r[7][i] = h * (d71 * k1[i] + d76 * k6[i] + d77 * k7[i] + d78 * k8[i] + d79 * k9[i] +
                         d710 * k10[i] + d711 * k11[i] + d712 * k12[i] + d713 * k13[i] +
                         d714 * k14[i] + d715 * k15[i] + d716 * k16[i]);
        }
        // the output times within a relative 1e-12 of the step's end are
        // its end (k every may round just past t_end), as in ezy
        for (double xo = static_cast<double>(st.nout) * o.every; xo <= xph * (1.0 + 1e-12);
             xo = static_cast<double>(++st.nout) * o.every) {
          const double th = std::min((xo - x) / h, 1.0), th1 = 1.0 - th;
          for (std::size_t i = 0; i < N; ++i)
            st.sink += r[0][i] + th * (r[1][i] + th1 * (r[2][i] + th * (r[3][i] + th1 *
                       (r[4][i] + th * (r[5][i] + th1 * (r[6][i] + th * r[7][i]))))));
        }
      }
      y = yn;
      x = xph;
      if (dense) {
        k1 = k13;
      } else {
        // The 13th evaluation, at the new state, is the next step's first
        // stage (FSAL). A projecting hook moves the state first, so the
        // evaluation is at the projected state and costs nothing extra.
        post(x, y);
        f(x, y, k1);
        ++st.nfcn;
      }
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
