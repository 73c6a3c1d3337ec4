"""`ezy.plan` and `ezy.gait_optimize` from a notebook cell: a sleigh typed
as text planned from rest to rest against its closed form, and against
the command line on the same text; an unreachable target refused with
its violation; the kinematic snake's best circle centre against the
command line's and the library's optimum."""

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import ezy

from test_ezy import cli

SLEIGH = """/// A sleigh: one body on a skate behind its centre of mass.
pub struct Sleigh {
    param m = 2.0;
    param I = 0.1;
    param a = 0.5;
    body s(x, y, phi) { mass: m, inertia: I }
    point P on s at (-a, 0);
    skate P: P along (1, 0);
}
"""

MASS, D, T = 2.0, 1.0, 2.0


def sleigh_scene(model):
    """The sleigh at rest, pushed along its skate by `push.fx` [N]."""
    return ezy.scene(
        model=model,
        name="sleigh-push",
        t_end=T,
        initial={"q": {"x": 0.0, "y": 0.0, "phi": 0.0}, "qd": {"x": 0.0, "phi": 0.0}},
        integrator={"method": "dop853", "rtol": 1e-12, "atol": 1e-12},
        effects={"push": {"kind": "force", "at": "s", "frame": "body", "fx": {"constant": 0.0}}},
    )


def test_a_sleigh_typed_in_a_cell_is_planned_to_its_closed_form(tmp_path):
    m = ezy.Model(SLEIGH)
    plan = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4)
    assert isinstance(plan, pd.DataFrame)
    # least effort from rest to rest: F(t) = m 6 d / T^2 (1 - 2 t / T),
    # linear, so 4 segments hold it; effort 12 d^2 m^2 / T^3
    force = MASS * 6.0 * D / T**2 * (1.0 - 2.0 * plan["t"] / T)
    assert np.max(np.abs(plan["push.fx"] - force)) <= 1e-6 * MASS * 6.0 * D / T**2
    s = plan.attrs["summary"]
    assert s["status"].iloc[0] == "optimal"
    cost = 12.0 * D**2 * MASS**2 / T**3
    assert abs(s["effort"].iloc[0] - cost) <= 1e-8 * cost
    # the verification run (an ordinary run of the planned input) ends at the target
    assert abs(s["run_error_x"].iloc[0]) <= 1e-6 and abs(s["run_error_xd"].iloc[0]) <= 1e-6
    assert "push.fx" in plan.attrs["units"] and "optimal" in plan.attrs["report"]
    # the plan as the next one's warm start: optimal within the least
    # budget (2 evaluations), where the scene's zero force is not
    again = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, evaluations=2,
                     guess=plan)
    assert again.attrs["summary"]["status"].iloc[0] == "optimal"
    with pytest.raises(ezy.EzyError, match="infeasible|not converged"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, evaluations=2)
    with pytest.raises(TypeError, match="guess"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, guess=3)
    # the command line on the same text: the same table, number for number
    (tmp_path / "sleigh.ezy").write_text(SLEIGH)
    toml = tmp_path / "push.toml"
    toml.write_text(
        'name = "sleigh-push"\ndescription = "a sleigh pushed"\nmodel = "sleigh.ezy"\nt_end = 2.0\n'
        '[initial]\nq = { x = 0.0, y = 0.0, phi = 0.0 }\nqd = { x = 0.0, phi = 0.0 }\n'
        '[integrator]\nmethod = "dop853"\nrtol = 1e-12\natol = 1e-12\n'
        '[effects.push]\nkind = "force"\nat = "s"\nframe = "body"\nfx = { constant = 0.0 }\n'
    )
    out = tmp_path / "out"
    code, _, err = cli("plan", str(toml), "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "4",
                       "--no-figures", "--out", str(out))
    assert code == 0, err
    table = pd.read_csv(out / "plan.csv", comment="#")
    assert list(table.columns) == list(plan.columns)
    assert np.array_equal(table.to_numpy(), plan.to_numpy())


def test_an_unreachable_target_raises_with_its_violation():
    m = ezy.Model(SLEIGH)
    # |F| <= 0.1 N moves the 2 kg sleigh rest to rest at most a T^2 / 4 = 0.05 m
    with pytest.raises(ezy.EzyError, match="infeasible"):
        ezy.plan(sleigh_scene(m), input="push.fx", bound={"push.fx": (-0.1, 0.1)}, to={"x": D}, at_rest=True,
                 segments=4)


def test_plan_refuses_bad_keywords_by_name():
    m = ezy.Model(SLEIGH)
    with pytest.raises(ezy.EzyError, match="push.fx.*2:1|2:1.*push.fx"):
        ezy.plan(sleigh_scene(m), input="push.fx", bound={"push.fx": (2.0, 1.0)}, to={"x": D})
    with pytest.raises(TypeError, match="segments"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, segments="four")
    with pytest.raises(TypeError, match="bound"):
        ezy.plan(sleigh_scene(m), input="push.fx", bound={"push.fx": "wide"}, to={"x": D})
    with pytest.raises(ezy.EzyError, match="nope"):
        ezy.plan(sleigh_scene(m), input="nope.fx", to={"x": D})


CIRCLE = "alpha1=0.7+0.6*cos(t),alpha2=-0.6+0.6*sin(t)"


def test_the_snakes_best_circle_centre_is_the_command_lines(tmp_path):
    best = ezy.gait_optimize("kinematic-snake", gait=CIRCLE, maximize="dy", order="second", centre_only=True)
    rows = best.set_index("coefficient")
    # the library's optimum (a dense scan of `predict` agrees to its 0.006)
    assert abs(rows.loc["alpha1.a0", "optimum"] - 1.056717) <= 1e-5
    assert abs(rows.loc["alpha2.a0", "optimum"] + 1.056717) <= 1e-5
    assert len(best.attrs["history"]) >= 2 and "dy" in best.attrs["report"]
    out = tmp_path / "out"
    code, _, err = cli("gait-optimize", "--gait", CIRCLE, "--maximize", "dy", "--order", "second", "--centre-only",
                       "--no-figures", "--out", str(out))
    assert code == 0, err
    table = pd.read_csv(out / "gait_optimum.csv", comment="#")
    assert np.array_equal(table["optimum"].to_numpy(), best["optimum"].to_numpy())
    with pytest.raises(TypeError, match="maximize"):
        ezy.gait_optimize("kinematic-snake", gait=CIRCLE)
    with pytest.raises(TypeError, match="margin"):
        ezy.gait_optimize("kinematic-snake", gait=CIRCLE, maximize="dx", margin="wide")


ROLLER = """/// The EzyRoller: a rear frame (skate A) and a steering fork (skate C)
/// joined by a hinge at B.
pub struct Roller {
    param a = 0.2;
    param b = 0.6;
    param c = 0.1;
    param d = 0.1;
    param m1 = 46.0;
    param I1 = 10.0;
    param m2 = 1.0;
    param I2 = 0.005;
    body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
    body body2(x2, y2, phi2) { mass: m2, inertia: I2 }
    point A on body1 at (-a, 0);
    point B1 on body1 at (b, 0);
    point B2 on body2 at (-d, 0);
    point C on body2 at (c, 0);
    hinge B: B1 = B2;
    skate A: A along (1, 0);
    skate C: C along (1, 0);
}
"""


def roller_scene(model):
    """The EzyRoller at rest, fork trailing, its hinge motor `2 cos(pi t)` N m, 8 s."""
    return ezy.scene(
        model=model,
        name="roller-plan",
        t_end=8.0,
        initial={"q": {"x1": 0.0, "y1": 0.0, "phi1": 0.0, "phi2": np.pi}, "qd": {"x1": 0.0, "phi1": 0.0}},
        integrator={"method": "dop853", "rtol": 1e-11, "atol": 1e-11},
        effects={"motor": {"kind": "hinge-motor", "hinge": "B", "torque": {"cos": {"amplitude": 2.0, "omega": np.pi}}}},
    )


def test_the_ezyroller_typed_in_a_cell_goes_one_metre_ahead():
    """1 m ahead on its line, fork straight and still, least squared torque
    on 10 segments (single shooting): the effort of ezy-core's library test
    of the same program on the compiled model (5.193432414, the model here
    derived from text at run time) to 1e-6, the verification run within
    1e-6 of every target component; rest to rest, which no hinge torque
    reaches (the guide's "Planning gaits and maneuvers"), raises
    infeasible."""
    m = ezy.Model(ROLLER)
    to = {"x1": 1.0, "y1": 0.0, "phi1": 0.0, "phi2": np.pi, "phi2d": 0.0}
    plan = ezy.plan(roller_scene(m), input="motor.torque", bound={"motor.torque": (-10.0, 10.0)}, to=to,
                    segments=10, intervals=1)
    s = plan.attrs["summary"]
    assert s["status"].iloc[0] == "optimal"
    assert abs(s["effort"].iloc[0] - 5.193432414) <= 1e-6 * 5.193432414
    for name in to:
        assert abs(s[f"run_error_{name}"].iloc[0]) <= 1e-6, name
    assert np.all(np.abs(plan["motor.torque"]) <= 10.0)
    with pytest.raises(ezy.EzyError, match="infeasible"):
        ezy.plan(roller_scene(m), input="motor.torque", bound={"motor.torque": (-10.0, 10.0)}, to={"x1": 1.0},
                 at_rest=True, segments=10, evaluations=60)


def effort_of_samples(t, q, qd, u):
    """The effort of the piecewise-linear force recomputed from its node
    samples, sum_k h_k / 3 (u_k^2 + u_k u_k+1 + u_k+1^2), with its
    gradient with respect to u (q and qd left out: zeros)."""
    h3 = np.diff(t) / 3.0
    a, b = u[:-1, 0], u[1:, 0]
    value = float(np.sum(h3 * (a * a + a * b + b * b)))
    g = np.zeros_like(u)
    g[:-1, 0] += h3 * (2.0 * a + b)
    g[1:, 0] += h3 * (a + 2.0 * b)
    return value, {"u": g}


def test_the_effort_as_a_python_objective_plans_as_the_built_in_one():
    """Oracle: an objective of the caller's that recomputes the effort
    exactly from the input samples, with the effort's weight 0, plans as
    the built-in effort (the closed form's forces) to 1e-8 relative, its
    gradient given (exact) or differenced by ezy from the value alone."""
    m = ezy.Model(SLEIGH)
    built_in = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4)
    base = built_in.attrs["summary"]
    assert base["objective"].iloc[0] == "effort" and base["objective_gradient"].iloc[0] == "exact"
    size = np.max(np.abs(built_in["push.fx"]))
    shapes = []

    def value_only(t, q, qd, u):
        shapes.append((t.shape, q.shape, qd.shape, u.shape))
        return effort_of_samples(t, q, qd, u)[0]

    for f, how in [(effort_of_samples, "exact"), (value_only, "differenced")]:
        plan = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, objective=f,
                        effort_weight=0.0)
        s = plan.attrs["summary"]
        assert s["status"].iloc[0] == "optimal", plan.attrs["report"]
        assert s["objective_gradient"].iloc[0] == how
        assert s["objective"].iloc[0] == f.__name__
        assert np.max(np.abs(plan["push.fx"] - built_in["push.fx"])) <= 1e-8 * size
        assert abs(s["objective_value"].iloc[0] - base["objective_value"].iloc[0]) <= 1e-8 * base["effort"].iloc[0]
        assert f.__name__ in plan.attrs["report"] and how in plan.attrs["report"]
    # the samples' shapes: t (N + 1,), q and qd (N + 1, nq), u (N + 1, inputs)
    assert shapes[0] == ((5,), (5, 3), (5, 3), (5, 1))


def test_an_exception_in_the_objective_reaches_the_caller():
    m = ezy.Model(SLEIGH)

    class Custom(Exception):
        pass

    def broken(t, q, qd, u):
        raise Custom("no objective here")

    with pytest.raises(Custom, match="no objective here"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, objective=broken)

    def not_finite(t, q, qd, u):
        return float("nan")

    with pytest.raises(ezy.EzyError, match="not_finite.*NaN"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, objective=not_finite)
    with pytest.raises(TypeError, match="objective"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, objective=3)


def driven_roller_scene(model):
    """The EzyRoller typed with its hinge driven (`drive D: hinge B;`),
    viscous rolling resistance 1 N s/m at both skates, its fork swinging
    `-pi + 0.3 sin(pi t)` (the drive-prescribed scene's)."""
    return ezy.scene(
        model=model,
        name="roller-gait",
        t_end=30.0,
        initial={"q": {"x1": 0.0, "y1": 0.0, "phi1": 0.0}, "qd": {"x1": 0.0}},
        integrator={"method": "dop853", "rtol": 1e-10, "atol": 1e-10},
        drives={"D": {"angle": {"harmonics": [{"amplitude": -np.pi, "omega": 0.0},
                                              {"amplitude": 0.3, "omega": np.pi, "phase": -np.pi / 2}]}}},
        effects={"rolling_A": {"kind": "rolling-viscous", "skate": "A", "damping": 1.0},
                 "rolling_C": {"kind": "rolling-viscous", "skate": "C", "damping": 1.0}},
    )


def test_a_mixed_systems_gait_typed_in_a_cell_is_optimized():
    """A mixed system's gait (the EzyRoller typed as text with a drive, its
    momentum carried between strokes) over the drive's Fourier
    coefficients: the fastest swing is the command line's on the compiled
    model (`ezy optimize --gait`, the guide's numbers: 2.8167708808559566
    m/s at D.a0 = -3.0965841244286905, D.a1 = 0.4 on its bound) to 1e-8;
    an objective of the caller's own over the run (the final x1 with its
    derivatives) is the same search as the built-in metric, to the bit."""
    m = ezy.Model(ROLLER.replace("hinge B: B1 = B2;", "hinge B: B1 = B2;\n    drive D: hinge B;"))
    over = {"D.a0": (-np.pi - 0.5, -np.pi + 0.5), "D.a1": (0.05, 0.4)}
    o = ezy.optimize(driven_roller_scene(m), gait="D=-pi+0.1+0.3*cos(t)", over=over,
                     maximize="gait.mean_forward_speed", grid=0)
    assert list(o.columns) == ["D.a0", "D.a1", "gait.mean_forward_speed"]
    assert o["D.a1"][0] == 0.4
    assert abs(o["D.a0"][0] - -3.0965841244286905) <= 1e-8
    assert abs(o["gait.mean_forward_speed"][0] - 2.8167708808559566) <= 1e-8 * 2.82
    assert "D.a1 is at a bound" in o.attrs["report"]

    def final_x1(run):
        return run["x1"].iloc[-1], [run[f"dx1/d{p}"].iloc[-1] for p in run.attrs["parameters"]]

    kw = dict(gait="D=-pi+0.3*cos(t)", over={"D.a1": (0.05, 0.4)}, grid=0, t_end=4.0)
    own = ezy.optimize(driven_roller_scene(m), maximize=final_x1, **kw)
    built_in = ezy.optimize(driven_roller_scene(m), maximize="final(x1)", **kw)
    assert own["D.a1"][0] == built_in["D.a1"][0]
    assert own["final_x1"][0] == built_in["final(x1)"][0]
    with pytest.raises(ezy.EzyError, match="has no drives"):
        ezy.optimize(roller_scene(ezy.Model(ROLLER)), gait="D=0.3*cos(t)", over={"D.a1": (0.0, 1.0)},
                     maximize="gait.mean_speed")


def test_a_speed_bound_on_the_path_as_text_and_as_a_function():
    """Oracle: the sleigh's speed at most 0.6 m/s at the nodes, 8 segments
    over 2 s: the continuous optimum is a piecewise-linear force (4.8 N to
    0 at 0.5 s, a coast, 0 to -4.8 N from 1.5 s), effort 7.68 N^2 s. The
    bound as text (`--path`) and as a function of the caller's own of one
    node's sample (its gradient given, or differenced) plan the same."""
    m = ezy.Model(SLEIGH)
    t = np.linspace(0.0, 2.0, 9)
    closed = np.where(t <= 0.5, 4.8 * (1 - t / 0.5), np.where(t >= 1.5, -4.8 * (t - 1.5) / 0.5, 0.0))
    text = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=8, path="xd<=0.6")
    s = text.attrs["summary"]
    assert s["status"].iloc[0] == "optimal", text.attrs["report"]
    assert abs(s["effort"].iloc[0] - 7.68) <= 1e-8 * 7.68
    assert s["inequalities"].iloc[0] == 8
    assert np.max(np.abs(text["push.fx"] - closed)) <= 1e-6 * 4.8
    shapes = []

    def speed(t, q, qd, u):
        shapes.append((t.shape, q.shape, u.shape))
        return qd[0, 0], {"qd": np.array([[1.0, 0.0, 0.0]])}

    def speed_value(t, q, qd, u):
        return qd[0, 0]

    for g in [speed, speed_value]:
        plan = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=8,
                        path=[(g, None, 0.6)])
        s = plan.attrs["summary"]
        assert s["status"].iloc[0] == "optimal", plan.attrs["report"]
        assert s["inequalities"].iloc[0] == 9, "nodes 0 to 8: a function may take the inputs"
        assert np.max(np.abs(plan["push.fx"] - closed)) <= 1e-6 * 4.8
    # one node's sample: t (1,), q (1, nq), u (1, inputs)
    assert shapes[0] == ((1,), (1, 3), (1, 1))
    with pytest.raises(ezy.EzyError, match="no coordinate `zd`"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, path="zd<=1")
    with pytest.raises(TypeError, match="path="):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, path=[3])


def test_least_time_and_effort_plus_time_from_a_cell():
    """Oracles: with |F| <= 1 N on 8 segments the least time is the
    discrete program's bang-bang force, T_N = sqrt(d / x_N(1)) (x_N(1) the
    distance of +1 to the middle node, 0 there, -1 after, over 1 s); with
    the effort plus T (time_weight=1) on 4 segments, T* = (36 m^2 d^2)^(1/4)
    = 2 sqrt(3) s (the least effort 12 m^2 d^2 / T^3 for each T), known to
    about 1e-5 (the objective is flat there)."""
    m = ezy.Model(SLEIGH)
    u = np.array([1.0] * 4 + [0.0] + [-1.0] * 4)
    h, x, v = 1.0 / 8.0, 0.0, 0.0
    for k in range(8):
        x += v * h + h * h * (2.0 * u[k] + u[k + 1]) / (6.0 * 2.0)
        v += h * (u[k] + u[k + 1]) / (2.0 * 2.0)
    t_n = np.sqrt(D / x)
    plan = ezy.plan(sleigh_scene(m), input="push.fx", bound={"push.fx": (-1.0, 1.0)}, to={"x": D}, at_rest=True,
                    segments=8, minimize="time", free_time=(1.0, 10.0))
    s = plan.attrs["summary"]
    assert s["status"].iloc[0] == "optimal", plan.attrs["report"]
    assert abs(s["t_end"].iloc[0] - t_n) <= 1e-8 * t_n
    assert np.max(np.abs(plan["push.fx"] - u)) <= 1e-6
    both = ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, at_rest=True, segments=4, time_weight=1.0,
                    free_time=(0.5, 20.0))
    s = both.attrs["summary"]
    assert s["status"].iloc[0] == "optimal", both.attrs["report"]
    assert abs(s["t_end"].iloc[0] - 2.0 * np.sqrt(3.0)) <= 1e-5 * 2.0 * np.sqrt(3.0)
    assert s["objective"].iloc[0] == "effort + time"
    with pytest.raises(TypeError, match="free_time"):
        ezy.plan(sleigh_scene(m), input="push.fx", to={"x": D}, segments=4, free_time=3.0)


def test_a_gait_metric_from_a_cell_is_the_command_lines():
    """`metric=` as a matrix gives the command line's `--metric` row by row:
    with G = 4 I the forward motion per length is half the identity's and
    a budget of 5 a budget of 2.5 in the identity: the same optimum (the
    budget binding, a rank margin of 0.3)."""
    circle = "alpha1=0.7+0.6*cos(t),alpha2=-0.6+0.6*sin(t)"
    a = ezy.gait_optimize("kinematic-snake", gait=circle, maximize="dx", order="first", per_length=True,
                          margin=0.3, budget=2.5)
    b = ezy.gait_optimize("kinematic-snake", gait=circle, maximize="dx", order="first", per_length=True,
                          margin=0.3, budget=5.0, metric=[[4.0, 0.0], [0.0, 4.0]])
    assert np.max(np.abs(a["optimum"] - b["optimum"])) <= 1e-9
    with pytest.raises(TypeError, match="metric"):
        ezy.gait_optimize("kinematic-snake", gait=circle, maximize="dx", budget=2.0, metric=3.0)
