"""CasADi + SUNDIALS CVODES on the reduced ODE of the EzyRoller drive scene.

The ODE is the one derived by hand in reduced.cpp (state [x1, y1, phi1,
phi2, u, w, W], u the forward speed of body 1, w = phi1d; Kane/Maggi
equations with the 2 x 2 mass matrix N^T M N solved in closed form),
written as a CasADi SX expression graph. CVODES runs its Adams-Moulton
method with functional (fixed-point) iteration, the non-stiff setting
(--bdf: BDF with Newton instead), one output at t = 60 s. The RHS is
JIT-compiled to C with CasADi's 'shell' compiler plugin (the system's C
compiler, -O3) when that works; otherwise (or with --no-jit) CasADi's
SX virtual machine evaluates it, and the tool column says so.

Prints one CSV line: tool,formulation,rtol,rhs_evals,integration_s_median,error
"""

import math
import sys
import os
import shutil
import tempfile

import casadi as ca

import peercommon as pc

a, b, c, d = pc.a, pc.b, pc.c, pc.d
m1, I1, m2, I2 = pc.m1, pc.I1, pc.m2, pc.I2
k, L = a + b, c + d
J, Ia = m2 * c * c + I2, I1 + m1 * a * a


def reduced_ode(t, y):
    """The right-hand side of reduced.cpp, on CasADi SX (see there for the
    derivation)."""
    phi1, phi2, u, w = y[2], y[3], y[4], y[5]
    s1, c1 = ca.sin(phi1), ca.cos(phi1)
    th = phi1 - phi2
    s, co = ca.sin(th), ca.cos(th)
    p = -(s * u + k * co * w) / L
    U2 = co * u - k * s * w
    thd = w - p
    tau = pc.M0 * ca.cos(pc.omega * t)
    M11 = m1 + m2 * co * co + J * s * s / (L * L)
    M12 = k * s * co * (J / (L * L) - m2)
    M22 = Ia + m2 * k * k * s * s + J * k * k * co * co / (L * L)
    R1 = (tau * s / L + m1 * a * w * w - m2 * c * co * p * p - m2 * c * s * p * U2 / L
          - m2 * L * co * p * thd - J * s * U2 * thd / (L * L))
    R2 = (tau * (1.0 + k * co / L) - m1 * a * u * w + m2 * c * k * s * p * p
          - m2 * c * k * co * p * U2 / L + m2 * k * L * s * p * thd - J * k * co * U2 * thd / (L * L))
    det = M11 * M22 - M12 * M12
    return ca.vertcat(c1 * u - a * s1 * w, s1 * u + a * c1 * w, w, p,
                      (M22 * R1 - M12 * R2) / det, (M11 * R2 - M12 * R1) / det, tau * (w - p))


def build(args, jit):
    t = ca.SX.sym("t")
    y = ca.SX.sym("y", 7)
    dae = {"t": t, "x": y, "ode": reduced_ode(t, y)}
    opts = {"abstol": args.atol, "reltol": args.rtol, "max_num_steps": 10_000_000}
    if args.bdf:
        opts.update({"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"})
    else:
        opts.update({"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"})
    if jit:
        opts.update({"jit": True, "compiler": "shell",
                     "jit_options": {"flags": ["-O3"], "verbose": False, "cleanup": False},
                     "jit_temp_suffix": True, "jit_cleanup": False})  # removed below
    return ca.integrator("F", "cvodes", dae, 0.0, [pc.t_end], opts)


def main():
    no_jit = "--no-jit" in sys.argv
    bdf = "--bdf" in sys.argv
    sys.argv = [x for x in sys.argv if x not in ("--no-jit", "--bdf")]
    args = pc.parse_args(default_rtol=1e-12, default_reps=5)
    args.bdf = bdf
    ref = pc.load_reference(args.ref)
    y0 = [0.0, 0.0, 0.0, math.pi, 0.0, 0.0, 0.0]
    jit = not no_jit
    # JIT writes and compiles C files in the working directory: use a
    # scratch one
    cwd = os.getcwd()
    scratch = tempfile.mkdtemp(prefix="casadi-jit-")
    os.chdir(scratch)
    try:
        F = build(args, jit)
        F(x0=y0)  # compile / warm up
    except Exception as e:  # no compiler plugin or no compiler
        if not jit:
            raise
        print(f"casadi: JIT failed ({str(e).splitlines()[0]}), running without JIT", file=sys.stderr)
        jit = False
        F = build(args, jit)
    finally:
        os.chdir(cwd)
        shutil.rmtree(scratch, ignore_errors=True)  # the library stays loaded

    def once():
        out = F(x0=y0)
        return out["xf"].full().ravel()

    secs, yf = pc.median_time(args.reps, once)
    stats = F.stats()
    evals = int(stats.get("nfevals", -1))
    y13 = pc.full_from_reduced(yf[0], yf[1], yf[2], yf[3],
                               math.cos(yf[2]) * yf[4] - a * math.sin(yf[2]) * yf[5],
                               math.sin(yf[2]) * yf[4] + a * math.cos(yf[2]) * yf[5],
                               yf[5], -(math.sin(yf[2] - yf[3]) * yf[4]
                                        + k * math.cos(yf[2] - yf[3]) * yf[5]) / L, yf[6])
    method = "BDF/Newton" if args.bdf else "Adams/functional"
    tool = f"CasADi {ca.__version__} CVODES {method} ({'JIT C -O3' if jit else 'SX VM, no JIT'})"
    pc.report(tool, "reduced ODE (hand-derived; 7 states)", args, evals, secs, y13, ref)


if __name__ == "__main__":
    main()
