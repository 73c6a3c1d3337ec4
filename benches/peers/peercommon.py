"""What the Python peers share: the EzyRoller's parameters
(docs/physics.md Sec. 10.1, 10.3), the reference final state, the error
measure, the command line, the timing and the CSV line."""

import argparse
import math
import os
import statistics
import sys
import time

import numpy as np

# docs/physics.md Sec. 10.1
a, b, c, d = 0.2, 0.6, 0.1, 0.1
m1, I1, m2, I2 = 46.0, 10.0, 1.0, 0.005
# the drive scene, Sec. 10.3
M0, omega, t_end = 2.0, math.pi, 60.0

NAMES = ["x1", "y1", "phi1", "x2", "y2", "phi2",
         "x1d", "y1d", "phi1d", "x2d", "y2d", "phi2d", "W"]

HERE = os.path.dirname(os.path.abspath(__file__))


def load_reference(path):
    """q (6), qd (6), W at t = 60 s from reference.csv ('#' comments, a
    header line, one row)."""
    header = None
    with open(path) as fh:
        for line in fh:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if header is None:
                header = line.split(",")
            else:
                row = dict(zip(header, (float(v) for v in line.split(","))))
                return np.array([row[n] for n in NAMES])
    raise SystemExit(f"no data row in {path}")


def state_error(y13, ref):
    """max over q and qd (12 components) of |y - y_ref|."""
    return float(np.max(np.abs(np.asarray(y13[:12]) - ref[:12])))


def full_from_reduced(x1, y1, phi1, phi2, x1d, y1d, w1, w2, W):
    """q, qd, W from body 1's coordinates and velocities and the headings:
    the hinge gives body 2's centre of mass."""
    s1, c1, s2, c2 = math.sin(phi1), math.cos(phi1), math.sin(phi2), math.cos(phi2)
    return np.array([x1, y1, phi1, x1 + b * c1 + d * c2, y1 + b * s1 + d * s2, phi2,
                     x1d, y1d, w1, x1d - b * s1 * w1 - d * s2 * w2,
                     y1d + b * c1 * w1 + d * c2 * w2, w2, W])


def parse_args(default_rtol, default_reps):
    p = argparse.ArgumentParser()
    p.add_argument("--rtol", type=float, default=default_rtol)
    p.add_argument("--atol", type=float, default=None, help="default: rtol")
    p.add_argument("--reps", type=int, default=default_reps)
    p.add_argument("--ref", default=os.path.join(HERE, "reference.csv"))
    p.add_argument("--print-state", action="store_true")
    args = p.parse_args()
    if args.atol is None:
        args.atol = args.rtol
    args.reps = max(1, args.reps)
    return args


def median_time(reps, once):
    """Runs once() reps times; returns (median seconds, last result)."""
    times, out = [], None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = once()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def report(tool, formulation, args, evals, seconds, y13, ref):
    if args.print_state:
        for n, v, r in zip(NAMES, y13, ref):
            print(f"{n:6s} {v: .16e}  ref {r: .16e}  diff {v - r: .3e}", file=sys.stderr)
    print(f"{tool},{formulation},{args.rtol:.0e},{evals},{seconds:.6e},{state_error(y13, ref):.3e}")


def dop853_final(rhs, y0, args):
    """SciPy's DOP853 from t = 0 to t_end at the peer's tolerances; the
    final state (exits naming SciPy's message if it fails)."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=args.rtol, atol=args.atol)
    if sol.status != 0:
        raise SystemExit(f"solve_ivp failed: {sol.message}")
    return sol.y[:, -1]
