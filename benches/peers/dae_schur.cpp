// dae_schur.cpp -- ezy's formulation of the EzyRoller drive scene, by hand.
//
// State y = [q (6), qd (6), W] (13 components), q = [x1, y1, phi1, x2, y2,
// phi2]. The right-hand side solves the index-1 KKT system of
// docs/physics.md Sec. 5,
//
//   [ M  G^T ] [ qdd    ]   [ f      ]
//   [ G  0   ] [ lambda ] = [ -gamma ],
//
// by the Schur complement (range-space method):
//
//   (G M^-1 G^T) lambda = G M^-1 f + gamma,   qdd = M^-1 (f - G^T lambda),
//
// with G = [C_q; S] (4 x 6, 14 nonzeros) and gamma from Sec. 10.2, the
// 4 x 4 normal matrix written out entry by entry from G's sparsity and
// factored by a hand-written Cholesky. f = [0, 0, tau, 0, 0, -tau],
// W' = tau (phi1d - phi2d).
//
// After every accepted step the state is projected as ezy does by default
// (Sec. 6, mass-weighted, W = M): Gauss-Newton on the hinge rows C(q) = 0,
// q <- q - M^-1 C_q^T (C_q M^-1 C_q^T)^-1 C(q), until max|C| <= 1e-12 or 10
// iterations, then one least-squares step on all four velocity rows,
// qd <- qd - M^-1 G^T (G M^-1 G^T)^-1 G qd. The next step's first stage is
// evaluated at the projected state. --no-projection turns this off.
//
// Integrator: dop853.hpp (Hairer's DOP853, rtol = atol, one output at
// t = 60 s). Prints: tool,formulation,rtol,rhs_evals,integration_s_median,error

#include "common.hpp"
#include "dop853.hpp"

using namespace ezyroller;
using V = std::array<double, 13>;

namespace {

constexpr double i1 = 1.0 / m1, j1 = 1.0 / I1, i2 = 1.0 / m2, j2 = 1.0 / I2;

// The 4 x 4 symmetric matrix A = G M^-1 G^T at headings (s1, c1), (s2, c2);
// rows: hinge x, hinge y, skate A, skate C (docs/physics.md Sec. 10.2):
//   G = [ 1   0   -b s1  -1    0   -d s2 ]
//       [ 0   1    b c1   0   -1    d c2 ]
//       [-s1  c1  -a      0    0    0    ]
//       [ 0   0    0     -s2   c2   c    ]
struct Normal {
  double a00, a01, a02, a03, a11, a12, a13, a22, a33;  // a23 = 0
};

inline Normal normal(double s1, double c1, double s2, double c2) {
  Normal n;
  n.a00 = i1 + i2 + b * b * s1 * s1 * j1 + d * d * s2 * s2 * j2;
  n.a01 = -b * b * s1 * c1 * j1 - d * d * s2 * c2 * j2;
  n.a11 = i1 + i2 + b * b * c1 * c1 * j1 + d * d * c2 * c2 * j2;
  n.a02 = -s1 * i1 + a * b * s1 * j1;
  n.a12 = c1 * i1 - a * b * c1 * j1;
  n.a03 = s2 * i2 - c * d * s2 * j2;
  n.a13 = -c2 * i2 + c * d * c2 * j2;
  n.a22 = i1 + a * a * j1;
  n.a33 = i2 + c * c * j2;
  return n;
}

// Solves A x = r (4 x 4, A = LL^T; the zero a23 is kept as a structural zero
// of A, not of L).
inline void solve4(const Normal& A, const double r[4], double x[4]) {
  const double l00 = std::sqrt(A.a00);
  const double l10 = A.a01 / l00, l20 = A.a02 / l00, l30 = A.a03 / l00;
  const double l11 = std::sqrt(A.a11 - l10 * l10);
  const double l21 = (A.a12 - l20 * l10) / l11;
  const double l31 = (A.a13 - l30 * l10) / l11;
  const double l22 = std::sqrt(A.a22 - l20 * l20 - l21 * l21);
  const double l32 = (0.0 - l30 * l20 - l31 * l21) / l22;
  const double l33 = std::sqrt(A.a33 - l30 * l30 - l31 * l31 - l32 * l32);
  // L z = r
  const double z0 = r[0] / l00;
  const double z1 = (r[1] - l10 * z0) / l11;
  const double z2 = (r[2] - l20 * z0 - l21 * z1) / l22;
  const double z3 = (r[3] - l30 * z0 - l31 * z1 - l32 * z2) / l33;
  // L^T x = z
  x[3] = z3 / l33;
  x[2] = (z2 - l32 * x[3]) / l22;
  x[1] = (z1 - l21 * x[2] - l31 * x[3]) / l11;
  x[0] = (z0 - l10 * x[1] - l20 * x[2] - l30 * x[3]) / l00;
}

// The 2 x 2 block (hinge rows) solve C_q M^-1 C_q^T x = r.
inline void solve2(const Normal& A, const double r[2], double x[2]) {
  const double det = A.a00 * A.a11 - A.a01 * A.a01;
  x[0] = (A.a11 * r[0] - A.a01 * r[1]) / det;
  x[1] = (A.a00 * r[1] - A.a01 * r[0]) / det;
}

// out = G^T l (6), for the rows of G above.
inline void gt_mul(double s1, double c1, double s2, double c2, const double l[4], double out[6]) {
  out[0] = l[0] - s1 * l[2];
  out[1] = l[1] + c1 * l[2];
  out[2] = -b * s1 * l[0] + b * c1 * l[1] - a * l[2];
  out[3] = -l[0] - s2 * l[3];
  out[4] = -l[1] + c2 * l[3];
  out[5] = -d * s2 * l[0] + d * c2 * l[1] + c * l[3];
}

struct Dae {
  long evals = 0;

  void operator()(double t, const V& y, V& dy) {
    ++evals;
    const double s1 = std::sin(y[2]), c1 = std::cos(y[2]);
    const double s2 = std::sin(y[5]), c2 = std::cos(y[5]);
    const double x1d = y[6], y1d = y[7], w1 = y[8], x2d = y[9], y2d = y[10], w2 = y[11];
    const double tau = torque(t);
    // gamma = [h; s], docs/physics.md Sec. 10.2
    const double g0 = -b * w1 * w1 * c1 - d * w2 * w2 * c2;
    const double g1 = -b * w1 * w1 * s1 - d * w2 * w2 * s2;
    const double g2 = -w1 * (x1d * c1 + y1d * s1);
    const double g3 = -w2 * (x2d * c2 + y2d * s2);
    // r = G M^-1 f + gamma with M^-1 f = [0, 0, tau/I1, 0, 0, -tau/I2]
    const double t1 = tau * j1, t2 = -tau * j2;
    const double r[4] = {-b * s1 * t1 - d * s2 * t2 + g0, b * c1 * t1 + d * c2 * t2 + g1,
                         -a * t1 + g2, c * t2 + g3};
    double lambda[4], gtl[6];
    solve4(normal(s1, c1, s2, c2), r, lambda);
    gt_mul(s1, c1, s2, c2, lambda, gtl);
    for (int k = 0; k < 6; ++k) dy[k] = y[6 + k];
    dy[6] = -gtl[0] * i1;
    dy[7] = -gtl[1] * i1;
    dy[8] = (tau - gtl[2]) * j1;
    dy[9] = -gtl[3] * i2;
    dy[10] = -gtl[4] * i2;
    dy[11] = (-tau - gtl[5]) * j2;
    dy[12] = tau * (w1 - w2);
  }
};

// Mass-weighted coordinate projection (docs/physics.md Sec. 6).
inline void project(V& y) {
  double* q = y.data();
  double* qd = y.data() + 6;
  double s1 = std::sin(q[2]), c1 = std::cos(q[2]), s2 = std::sin(q[5]), c2 = std::cos(q[5]);
  double C[2] = {q[0] + b * c1 - q[3] + d * c2, q[1] + b * s1 - q[4] + d * s2};
  for (int it = 0; it <= 10; ++it) {
    if (std::max(std::fabs(C[0]), std::fabs(C[1])) <= 1e-12 || it == 10) break;
    const Normal A = normal(s1, c1, s2, c2);
    double x[2];
    solve2(A, C, x);
    // q -= M^-1 C_q^T x (C_q: the first two rows of G)
    q[0] -= x[0] * i1;
    q[1] -= x[1] * i1;
    q[2] -= (-b * s1 * x[0] + b * c1 * x[1]) * j1;
    q[3] -= -x[0] * i2;
    q[4] -= -x[1] * i2;
    q[5] -= (-d * s2 * x[0] + d * c2 * x[1]) * j2;
    s1 = std::sin(q[2]), c1 = std::cos(q[2]), s2 = std::sin(q[5]), c2 = std::cos(q[5]);
    C[0] = q[0] + b * c1 - q[3] + d * c2;
    C[1] = q[1] + b * s1 - q[4] + d * s2;
  }
  // velocities: one least-squares step on G qd = 0
  const double r[4] = {qd[0] - b * s1 * qd[2] - qd[3] - d * s2 * qd[5],
                       qd[1] + b * c1 * qd[2] - qd[4] + d * c2 * qd[5],
                       -s1 * qd[0] + c1 * qd[1] - a * qd[2],
                       -s2 * qd[3] + c2 * qd[4] + c * qd[5]};
  double x[4], gtx[6];
  solve4(normal(s1, c1, s2, c2), r, x);
  gt_mul(s1, c1, s2, c2, x, gtx);
  const double winv[6] = {i1, i1, j1, i2, i2, j2};
  for (int k = 0; k < 6; ++k) qd[k] -= winv[k] * gtx[k];
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  if (args.every > 0.0) {
    std::fprintf(stderr, "dae_schur has no dense output (--every is the reduced peer's)\n");
    return 2;
  }
  const auto ref = load_reference(args.ref);
  dop853::Options opt;
  opt.rtol = args.rtol;
  opt.atol = args.atol;
  V y{};
  long evals = 0;
  int status = 0;
  auto once = [&]() {
    // initial state (Sec. 10.3): x1 = y1 = phi1 = 0, phi2 = pi, the hinge
    // gives x2 = b + d = 0.5, y2 = d sin(pi) ~ 1.2e-17 (set as computed)
    y.fill(0.0);
    y[5] = pi;
    y[3] = b * std::cos(0.0) + d * std::cos(pi);
    y[4] = b * std::sin(0.0) + d * std::sin(pi);
    Dae f;
    dop853::Stats st;
    if (args.no_projection)
      status = dop853::integrate<13>(f, 0.0, y, t_end, opt, st);
    else
      status = dop853::integrate<13>(f, 0.0, y, t_end, opt, st, [](double, V& yy) { project(yy); });
    evals = f.evals;
  };
  const double secs = median_time(args.reps, once);
  return report(args, ref, status,
                args.no_projection ? "DAE index-1 Schur (no projection)"
                                   : "DAE index-1 Schur + mass-weighted projection",
                evals, secs, y);
}
