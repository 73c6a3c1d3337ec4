"""SymPy derives the reduced ODE of the EzyRoller, generates C for it
(sympy.utilities.autowrap, Cython backend, with common-subexpression
elimination), and SciPy solve_ivp(method='DOP853') integrates it.

Derivation, all symbolic (nothing taken from reduced.cpp):

1. Full coordinates q = [x1, y1, phi1, x2, y2, phi2], M = diag(m1, m1, I1,
   m2, m2, I2). The hinge (docs/physics.md Sec. 10.2) is solved for
   (x2, y2): q = q(p), p = [x1, y1, phi1, phi2], Q = dq/dp (6 x 4).
2. The skate rows S(q) qd = 0 (Sec. 10.2) become S(q(p)) Q pd = 0 (2 x 4).
   With the independent speeds v = [u, w], u = x1d cos phi1 + y1d sin phi1
   and w = phi1d, the 4 x 4 system [S Q; E] pd = [0; 0; v] is solved
   symbolically for pd = P(p) v; N = Q P gives qd = N v.
3. Maggi's (Kane's) equations N^T M N v' = N^T (f - M Ndot v), with Ndot =
   sum_j dN/dp_j pd_j and f = [0, 0, tau, 0, 0, -tau]; the 2 x 2 system
   is solved in closed form (adjugate / determinant).
4. RHS = [P v, v', tau (w - phi2d)] for the state [x1, y1, phi1, phi2,
   u, w, W] (7), compiled once per process.

If Cython or a C compiler is missing, the RHS falls back to
sympy.lambdify with NumPy (--lambdify forces it); the tool column says
which. Prints one CSV line:
tool,formulation,rtol,rhs_evals,integration_s_median,error
"""

import math
import shutil
import sys
import tempfile
import time

import numpy as np
import scipy
import sympy as sp

import peercommon as pc


def derive():
    a, b, c, d = sp.symbols("a b c d", positive=True)
    m1, I1, m2, I2, M0, om = sp.symbols("m1 I1 m2 I2 M0 omega", positive=True)
    t = sp.Symbol("t", real=True)
    x1, y1, phi1, phi2, u, w = sp.symbols("x1 y1 phi1 phi2 u w", real=True)
    p = sp.Matrix([x1, y1, phi1, phi2])
    v = sp.Matrix([u, w])
    # 1. the hinge solved for body 2's centre of mass
    q = sp.Matrix([x1, y1, phi1,
                   x1 + b * sp.cos(phi1) + d * sp.cos(phi2),
                   y1 + b * sp.sin(phi1) + d * sp.sin(phi2), phi2])
    Q = q.jacobian(p)
    M = sp.diag(m1, m1, I1, m2, m2, I2)
    # 2. skates, S(q) qd = 0, and the speed definitions E pd = v
    S = sp.Matrix([[-sp.sin(q[2]), sp.cos(q[2]), -a, 0, 0, 0],
                   [0, 0, 0, -sp.sin(q[5]), sp.cos(q[5]), c]])
    E = sp.Matrix([[sp.cos(phi1), sp.sin(phi1), 0, 0], [0, 0, 1, 0]])
    A = (S * Q).col_join(E)
    A = A.applyfunc(sp.simplify)
    P = A.LUsolve(sp.Matrix([[0, 0], [0, 0], [1, 0], [0, 1]]))
    P = P.applyfunc(lambda e: sp.trigsimp(sp.simplify(e)))
    N = (Q * P).applyfunc(sp.simplify)
    # 3. Maggi's equations
    pd = P * v
    Ndot = sp.zeros(6, 2)
    for j in range(4):
        Ndot += N.diff(p[j]) * pd[j]
    tau = M0 * sp.cos(om * t)
    f = sp.Matrix([0, 0, tau, 0, 0, -tau])
    # no further simplification: simplify() on N^T M N and on the
    # right-hand side takes minutes; the code generator's common
    # subexpression elimination does what matters for speed
    Mr = N.T * M * N
    R = N.T * (f - M * Ndot * v)
    det = Mr[0, 0] * Mr[1, 1] - Mr[0, 1] * Mr[1, 0]
    ud = (Mr[1, 1] * R[0] - Mr[0, 1] * R[1]) / det
    wd = (Mr[0, 0] * R[1] - Mr[1, 0] * R[0]) / det
    rhs = sp.Matrix([pd[0], pd[1], pd[2], pd[3], ud, wd, tau * (w - pd[3])])
    params = {a: pc.a, b: pc.b, c: pc.c, d: pc.d, m1: pc.m1, I1: pc.I1,
              m2: pc.m2, I2: pc.I2, M0: pc.M0, om: sp.Float(pc.omega)}  # not sp.pi: C99 has no M_PI
    rhs = rhs.subs(params)
    return t, [x1, y1, phi1, phi2, u, w], rhs


def compile_rhs(t, states, rhs, lambdify_only):
    W = sp.Symbol("W")
    Y = sp.MatrixSymbol("Y", 7, 1)
    sub = {s: Y[i, 0] for i, s in enumerate(states + [W])}
    expr = rhs.subs(sub)
    if not lambdify_only:
        try:
            from sympy.utilities.autowrap import autowrap
            from sympy.utilities.codegen import C99CodeGen
            tmp = tempfile.mkdtemp(prefix="sympy-autowrap-")
            fn = autowrap(expr, language="C", backend="cython", args=[t, Y], tempdir=tmp,
                          code_gen=C99CodeGen(project="ezyroller", cse=True),
                          verbose=False)
            shutil.rmtree(tmp, ignore_errors=True)  # the module stays loaded

            def f(tt, y):
                return fn(tt, y.reshape(7, 1)).ravel()

            return f, "autowrap Cython C99 -O3 + cse"
        except Exception as e:  # no Cython or no compiler
            print(f"sympy_codegen: autowrap failed ({str(e).splitlines()[0]}); using lambdify",
                  file=sys.stderr)
    g = sp.lambdify((t, Y), expr, modules="numpy", cse=True)

    def f(tt, y):
        return np.asarray(g(tt, y.reshape(7, 1)), dtype=float).ravel()

    return f, "lambdify NumPy + cse"


def main():
    lambdify_only = "--lambdify" in sys.argv
    sys.argv = [x for x in sys.argv if x != "--lambdify"]
    args = pc.parse_args(default_rtol=1e-12, default_reps=3)
    ref = pc.load_reference(args.ref)
    t0 = time.perf_counter()
    t, states, rhs = derive()
    t1 = time.perf_counter()
    f, how = compile_rhs(t, states, rhs, lambdify_only)
    t2 = time.perf_counter()
    print(f"sympy_codegen: derivation {t1 - t0:.2f} s, code generation and compilation {t2 - t1:.2f} s",
          file=sys.stderr)
    y0 = np.array([0.0, 0.0, 0.0, math.pi, 0.0, 0.0, 0.0])

    def once():
        counter = [0]

        def rhs_counted(tt, y):
            counter[0] += 1
            return f(tt, y)

        yf = pc.dop853_final(rhs_counted, y0, args)
        return yf, counter[0]

    secs, (yf, evals) = pc.median_time(args.reps, once)
    dy = f(pc.t_end, yf)  # phi2d at the end, from the ODE itself
    y13 = pc.full_from_reduced(yf[0], yf[1], yf[2], yf[3], dy[0], dy[1], dy[2], dy[3], yf[6])
    pc.report(f"SymPy {sp.__version__} {how} + SciPy {scipy.__version__} DOP853",
              "reduced ODE (SymPy-derived Maggi; 7 states)", args, evals, secs, y13, ref)


if __name__ == "__main__":
    main()
