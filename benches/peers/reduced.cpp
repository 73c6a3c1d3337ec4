// reduced.cpp -- the EzyRoller drive scene as a hand-derived minimal ODE.
//
// Derivation (symbols of docs/physics.md Sec. 10.1; s1 = sin phi1, ...).
//
// 1. Coordinates. The hinge, x2 = x1 + b cos phi1 + d cos phi2 and
//    y2 = y1 + b sin phi1 + d sin phi2, eliminates (x2, y2): the
//    coordinates are p = (x1, y1, phi1, phi2), with the hinge angle
//    th = phi1 - phi2 (th = -pi at the start; only sin th, cos th enter).
//
// 2. Independent speeds u = (u, w): u = x1d c1 + y1d s1, the forward speed
//    of body 1's centre of mass along its axis, and w = phi1d. Skate A
//    (-x1d s1 + y1d c1 = a w) fixes the lateral speed of body 1 to a w, so
//
//      x1d = c1 u - a s1 w,      y1d = s1 u + a c1 w,      phi1d = w.
//
//    In body 1's frame the hinge point B moves with (u, k w), k = a + b.
//    Body 2's centre of mass is r2 = rB + d e2 and skate C is at
//    rB + L e2, L = c + d, with e2 = (cos th, -sin th) and normal
//    n2 = (sin th, cos th) in body 1's frame. Skate C, n2 . v_C = 0, is
//    n2 . vB + L phi2d = 0:
//
//      p := phi2d = -(s u + k co w) / L,     s = sin th, co = cos th,
//
//    (L > 0: regular for every hinge angle). With the hinge,
//    x2d = x1d - b s1 w - d s2 p, y2d = y1d + b c1 w + d c2 p. This is the
//    null-space form qd = N(q) u.
//
// 3. Velocities in the body frames. Body 1's centre of mass: (u, a w) in
//    frame 1. Body 2's: v2 = vB + d p n2, in frame 2 (axis e2, normal n2)
//
//      v2 = (U2, -c p),     U2 = e2 . vB = co u - k s w,
//
//    (n2 . v2 = n2 . vB + d p = -L p + d p = -c p). The partial velocities
//    (Kane) are the derivatives of these by u and w:
//
//      body 1 CoM: (1, 0) and (0, a);  phi1d: 0 and 1
//      body 2 CoM: (co, c s / L) and (-k s, c k co / L);  phi2d: -s / L and -k co / L
//
// 4. Accelerations in the rotating frames, a = (vx' - W vy, vy' + W vx)
//    for a frame turning at rate W:
//
//      body 1: (u' - a w^2, a w' + u w)
//      body 2: (U2' + c p^2, -c p' + p U2)
//
//    with thd = w - p and, differentiating U2 and p,
//
//      U2' = co u' - k s w' + L p thd         (u s + k co w = -L p)
//      p'  = -(s u' + k co w' + U2 thd) / L.
//
// 5. Kane's equations (Maggi's form N^T M N u' = N^T (f - M Ndot u)):
//    sum over bodies of partial velocity . m a + partial angular
//    velocity . I alpha = generalized force. The motor, +tau on phi1 and
//    -tau on phi2, gives F_u = tau s / L, F_w = tau (1 + k co / L). With
//    J = m2 c^2 + I2 and Ia = I1 + m1 a^2, collecting u' and w':
//
//      [ M11 M12 ] [ u' ]   [ R1 ]
//      [ M12 M22 ] [ w' ] = [ R2 ]
//
//      M11 = m1 + m2 co^2 + J s^2 / L^2
//      M12 = k s co (J / L^2 - m2)
//      M22 = Ia + m2 k^2 s^2 + J k^2 co^2 / L^2
//      R1  = tau s / L + m1 a w^2 - m2 c co p^2 - m2 c s p U2 / L
//            - m2 L co p thd - J s U2 thd / L^2
//      R2  = tau (1 + k co / L) - m1 a u w + m2 c k s p^2 - m2 c k co p U2 / L
//            + m2 k L s p thd - J k co U2 thd / L^2
//
//    (the mass matrix is N^T M N, as it must be: T = u^T (N^T M N) u / 2 =
//    [m1 u^2 + Ia w^2 + m2 U2^2 + J p^2] / 2).
//
// 6. State: [x1, y1, phi1, phi2, u, w, W] (7), W' = tau (w - p). The
//    initial state is all zero except phi2 = pi.
//
// The full q, qd at t = 60 s are rebuilt from the hinge and qd = N u and
// compared with the reference. Integrator: dop853.hpp, rtol = atol.
// Prints: tool,formulation,rtol,rhs_evals,integration_s_median,error

#include "common.hpp"
#include "dop853.hpp"

using namespace ezyroller;
using V = std::array<double, 7>;

namespace {

constexpr double k = a + b, L = c + d;
constexpr double J = m2 * c * c + I2, Ia = I1 + m1 * a * a;

struct Reduced {
  long evals = 0;

  void operator()(double t, const V& y, V& dy) {
    ++evals;
    const double phi1 = y[2], phi2 = y[3], u = y[4], w = y[5];
    const double s1 = std::sin(phi1), c1 = std::cos(phi1);
    const double th = phi1 - phi2, s = std::sin(th), co = std::cos(th);
    const double p = -(s * u + k * co * w) / L;  // phi2d
    const double U2 = co * u - k * s * w;
    const double thd = w - p;
    const double tau = torque(t);
    const double M11 = m1 + m2 * co * co + J * s * s / (L * L);
    const double M12 = k * s * co * (J / (L * L) - m2);
    const double M22 = Ia + m2 * k * k * s * s + J * k * k * co * co / (L * L);
    const double R1 = tau * s / L + m1 * a * w * w - m2 * c * co * p * p - m2 * c * s * p * U2 / L -
                      m2 * L * co * p * thd - J * s * U2 * thd / (L * L);
    const double R2 = tau * (1.0 + k * co / L) - m1 * a * u * w + m2 * c * k * s * p * p -
                      m2 * c * k * co * p * U2 / L + m2 * k * L * s * p * thd -
                      J * k * co * U2 * thd / (L * L);
    const double det = M11 * M22 - M12 * M12;
    dy[0] = c1 * u - a * s1 * w;
    dy[1] = s1 * u + a * c1 * w;
    dy[2] = w;
    dy[3] = p;
    dy[4] = (M22 * R1 - M12 * R2) / det;
    dy[5] = (M11 * R2 - M12 * R1) / det;
    dy[6] = tau * (w - p);
  }
};

// q, qd, W from the reduced state
std::array<double, 13> full_state(const V& y) {
  const double x1 = y[0], y1 = y[1], phi1 = y[2], phi2 = y[3], u = y[4], w = y[5];
  const double s1 = std::sin(phi1), c1 = std::cos(phi1), s2 = std::sin(phi2), c2 = std::cos(phi2);
  const double th = phi1 - phi2, s = std::sin(th), co = std::cos(th);
  const double p = -(s * u + k * co * w) / L;
  const double x1d = c1 * u - a * s1 * w, y1d = s1 * u + a * c1 * w;
  return {x1, y1, phi1, x1 + b * c1 + d * c2, y1 + b * s1 + d * s2, phi2,
          x1d, y1d, w, x1d - b * s1 * w - d * s2 * p, y1d + b * c1 * w + d * c2 * p, p, y[6]};
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  const auto ref = load_reference(args.ref);
  dop853::Options opt;
  opt.rtol = args.rtol;
  opt.atol = args.atol;
  opt.every = args.every;
  V y{};
  long evals = 0, samples = 0;
  double sink = 0.0;
  int status = 0;
  auto once = [&]() {
    y.fill(0.0);
    y[3] = pi;
    Reduced f;
    dop853::Stats st;
    status = dop853::integrate<7>(f, 0.0, y, t_end, opt, st);
    evals = f.evals;
    samples = st.nout;
    sink = st.sink;
  };
  const double secs = median_time(args.reps, once);
  // the samples' sum is printed, so that no compiler drops their work
  if (opt.every > 0.0) std::fprintf(stderr, "%ld dense-output samples, their sum %.17g\n", samples, sink);
  char what[96] = "reduced ODE (Kane/Maggi; 7 states)";
  if (opt.every > 0.0)
    std::snprintf(what, sizeof what, "reduced ODE (Kane/Maggi; 7 states), dense output every %g s", opt.every);
  return report(args, ref, status, what, evals, secs, full_state(y));
}
