"""SciPy solve_ivp(method='DOP853') on ezy's DAE formulation with a NumPy
right-hand side.

State y = [q (6), qd (6), W]; the RHS assembles the 10 x 10 KKT matrix
[M G^T; G 0] of docs/physics.md Sec. 5 with G = [C_q; S] and gamma from
Sec. 10.2, and solves it with np.linalg.solve. No projection: SciPy's
integrators have no hook for it, so the hinge and skate constraints drift
(at the integrator's error level). Prints one CSV line:
tool,formulation,rtol,rhs_evals,integration_s_median,error
"""

import math

import numpy as np
import scipy

import peercommon as pc

a, b, c, d = pc.a, pc.b, pc.c, pc.d
MASS = np.array([pc.m1, pc.m1, pc.I1, pc.m2, pc.m2, pc.I2])


def make_rhs():
    K = np.zeros((10, 10))
    K[range(6), range(6)] = MASS
    r = np.zeros(10)
    G = np.zeros((4, 6))
    counter = [0]

    def rhs(t, y):
        counter[0] += 1
        x1d, y1d, w1, x2d, y2d, w2 = y[6:12]
        s1, c1 = math.sin(y[2]), math.cos(y[2])
        s2, c2 = math.sin(y[5]), math.cos(y[5])
        tau = pc.M0 * math.cos(pc.omega * t)
        G[0] = (1.0, 0.0, -b * s1, -1.0, 0.0, -d * s2)
        G[1] = (0.0, 1.0, b * c1, 0.0, -1.0, d * c2)
        G[2] = (-s1, c1, -a, 0.0, 0.0, 0.0)
        G[3] = (0.0, 0.0, 0.0, -s2, c2, c)
        K[6:, :6] = G
        K[:6, 6:] = G.T
        r[:6] = (0.0, 0.0, tau, 0.0, 0.0, -tau)
        r[6:] = (b * w1 * w1 * c1 + d * w2 * w2 * c2,       # -gamma
                 b * w1 * w1 * s1 + d * w2 * w2 * s2,
                 w1 * (x1d * c1 + y1d * s1),
                 w2 * (x2d * c2 + y2d * s2))
        sol = np.linalg.solve(K, r)
        dy = np.empty(13)
        dy[:6] = y[6:12]
        dy[6:12] = sol[:6]
        dy[12] = tau * (w1 - w2)
        return dy

    return rhs, counter


def main():
    args = pc.parse_args(default_rtol=1e-12, default_reps=3)
    ref = pc.load_reference(args.ref)
    y0 = np.zeros(13)
    y0[5] = math.pi
    y0[3] = b + d * math.cos(math.pi)
    y0[4] = d * math.sin(math.pi)

    def once():
        rhs, counter = make_rhs()
        yf = pc.dop853_final(rhs, y0, args)
        return yf, counter[0]

    secs, (y, evals) = pc.median_time(args.reps, once)
    pc.report(f"SciPy {scipy.__version__} solve_ivp DOP853 + NumPy",
              "DAE index-1 KKT np.linalg.solve (no projection)", args, evals, secs, y, ref)


if __name__ == "__main__":
    main()
