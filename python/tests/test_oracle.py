"""The oracle harness (docs/dev/oracle.md) through `import ezy` (issue 82).

The Rust harness in tests/oracle/ checks every number class a command
prints against an oracle that shares no code with it. Here the same items
go through the public Python API only, as a notebook's user would reach
them: a model typed in a cell (`ezy.Model(text)`), a scene made from
keywords, `ezy.analyze`, `ezy.run`, `ezy.sensitivity`, `ezy.optimize`;
Ctrl-C during each long call; the same call in two threads.

What Python cannot set: the periodic search's own tolerances (DOP853 at
rtol = atol = 1e-11, Newton to 1e-9 in `ezy analyze` and `ezy optimize`,
`PeriodicSettings::default()`): `rtol`/`atol` keywords set the scene's
run, not the shooting. The tolerances below are sized for those.
"""

import re
import threading
import time

import numpy as np
import pytest

import ezy
from test_ezy import interrupted_after, sigint_raises  # noqa: F401 (a fixture)

# A sleigh carrying an internal rotor whose hinge angle is prescribed
# (tests/data/oracle/rotor_drive.ezy), typed as a notebook's cell would.
ROTOR_DRIVE = """
/// A sleigh carrying an internal rotor whose hinge angle is prescribed.
pub struct RotorSleigh {
    param m = 1.0;
    param I = 0.1;
    param mr = 0.5;
    param Ir = 0.05;
    param a = 0.5;
    body s(x, y, phi) { mass: m, inertia: I }
    body r(xr, yr, th) { mass: mr, inertia: Ir }
    point C on s at (0, 0);
    point R on r at (0, 0);
    point P on s at (-a, 0);
    hinge H: C = R;
    skate P: P along (1, 0);
    drive psi: hinge H;
}
"""


def drive_keys(**changes):
    """tests/data/oracle/rotor-drive.toml as a scene's keywords: the rotor
    swung as psi = sin(3 t), linear drag on the sleigh."""
    keys = dict(
        name="rotor-drive",
        description="a sleigh propelled by a rotor whose angle to the sleigh is prescribed, with drag",
        t_end=60.0,
        initial={"q": {"x": 0.0, "y": 0.0, "phi": 0.0}, "qd": {"x": 0.0, "phi": 0.0}},
        integrator={"method": "dop853", "rtol": 1e-10, "atol": 1e-10},
        output={"every": 0.01, "include": ["energy", "effects"]},
        drives={"psi": {"angle": {"sin": {"amplitude": 1.0, "omega": 3.0}}}},
        effects={"drag": {"kind": "linear-drag", "body": "s", "c": 0.5, "c_rot": 0.05}},
    )
    keys.update(changes)
    return keys


_MODEL = []


def rotor_drive(**changes):
    """The scene on the model typed above (the model derived once)."""
    if not _MODEL:
        _MODEL.append(ezy.Model(ROTOR_DRIVE))
    return ezy.scene(model=_MODEL[0], **drive_keys(**changes))


# the quantities of periodic.csv that --wrt differentiates
QUANTITIES = ["period", "mean_speed", "mean_forward_speed", "dx", "dy", "dheading", "mean_power", "efficiency"]


def gait(scene, **kw):
    """The gait's row of `.periodic` (a Series)."""
    return ezy.analyze(scene, **kw).periodic.iloc[0]


def test_a_gaits_derivatives_are_richardson_differences_of_gaits():
    scene = rotor_drive()
    row = gait(scene, wrt=["psi.omega", "drag.c"])
    # Central differences of gaits found by separate analyses at p +- h,
    # p +- h/2 and p +- h/4, extrapolated twice (Richardson: the h^2, then
    # the h^4 term removed), h = 1e-3 |p| for the drag and 5e-4 |p| for
    # the frequency, which has a lever: the fixed point is taken at the
    # run's end, t0 = 60 s, at every frequency, so the drive's phase there
    # moves by t0 h (0.18 rad at h = 1e-3 |p|, where the forward speed,
    # dx and dy, which depend on that phase, kept a term of 8e-4 of their
    # derivative after one extrapolation and 6e-7 after two).
    # Each gait carries the shooting's error (DOP853 at 1e-11, Newton to
    # 1e-9; neither settable from Python): its integrals over a period
    # (the mean power, hence the efficiency) are the run's to about
    # EPS = 1e-10 relative (two analyses of the same gait, with and
    # without `wrt`, gave mean powers 4e-11 apart), which the differences
    # divide by their steps: the extrapolation's combination
    # (64 d(h/4) - 20 d(h/2) + d(h)) / 45 carries at most
    # 6.6 EPS |Q| / h of noise for a quantity Q.
    EPS = 1e-10
    for name, p, h in [("psi.omega", 3.0, 1.5e-3), ("drag.c", 0.5, 5e-4)]:

        def slope(h):
            a, b = gait(scene, set={name: p + h}), gait(scene, set={name: p - h})
            return np.array([(a[q] - b[q]) / (2 * h) for q in QUANTITIES])

        d1, d2, d3 = slope(h), slope(h / 2), slope(h / 4)
        noise = 6.6 * EPS * np.array([abs(row[q]) for q in QUANTITIES]) / h
        r1, r2 = d2 + (d2 - d1) / 3, d3 + (d3 - d2) / 3
        rich = r2 + (r2 - r1) / 15
        reported = np.array([row[f"d{q}/d{name}"] for q in QUANTITIES])
        largest = np.max(np.abs(rich))
        for q, r, want, near, n in zip(QUANTITIES, reported, rich, r2, noise):
            # a quantity held at 0 by symmetry (the straight gait's heading
            # change: its derivative ~1e-11, the shooting's rounding) is
            # compared with the gait's largest derivative; the others with
            # their own size, at least a tenth of the largest
            scale = largest if abs(want) < 1e-6 * largest else max(abs(want), 0.1 * largest)
            oracle = abs(want - near)
            print(
                f"d{q}/d{name}: {r:.12e} against {want:.12e} ({abs(r - want) / scale:.1e} of its scale;"
                f" Richardson change {oracle:.1e}, noise bound {n:.1e})"
            )
            # the oracle's truncation, bounded by its last extrapolation's
            # change: below 1e-6 of the scale (it measured 4e-8 at most)
            assert oracle <= 1e-6 * scale, (q, name, oracle, scale)
            # 1e-6 of the scale, plus three times the oracle's truncation
            # and its noise bound (the efficiency's is the largest, 3e-6 in
            # the frequency and 9e-6 in the drag: it came 4e-7 and 3e-7
            # off; the other quantities within 6e-9 of their scale)
            assert abs(r - want) <= 1e-6 * scale + 3 * oracle + n, (q, name, r, want)


def test_a_gaits_mean_power_is_the_drives_work_over_a_period_of_a_run():
    scene = rotor_drive()
    g = gait(scene)
    period, t0, power = g["period"], g["t0"], g["mean_power"]
    assert power > 1e-3
    # efficiency = mean speed / mean power, as defined; both printed to
    # the last digit, so to rounding (1e-12)
    assert abs(g["efficiency"] - g["mean_speed"] / power) <= 1e-12 * g["efficiency"]
    # a run from the fixed point over one period, the drive at the orbit's
    # phase (psi = sin(3 (t + t0))), at 1e-12
    run = ezy.scene(
        model=_MODEL[0],
        **drive_keys(
            name="rotor-drive-period",
            t_end=period,
            initial={"q": {"x": g["x"], "y": g["y"], "phi": g["phi"]}, "qd": {"x": g["xd"], "phi": g["phid"]}},
            integrator={"method": "dop853", "rtol": 1e-12, "atol": 1e-12},
            output={"every": period, "include": ["energy", "effects"]},
            drives={"psi": {"angle": {"sin": {"amplitude": 1.0, "omega": 3.0, "phase": 3.0 * t0}}}},
        ),
    ).run()
    assert abs(run.t[-1] - period) <= 1e-12 * period
    w_psi, w_drag = run["W_psi"][-1], run["W_drag"][-1]
    print(f"gait {power} W; a run over a period: W_psi/T {w_psi / period}, -W_drag/T {-w_drag / period}")
    # the fixed point is Newton's to 1e-9 and the run's work is the
    # integrator's to ~1e-11: 1e-8 relative leaves a margin of 10 for the
    # power over a period started off the orbit by 1e-9
    assert abs(w_psi / period - power) <= 1e-8 * power
    # and the drag dissipates what the drive puts in (a periodic orbit's
    # energy returns to its start)
    assert abs(-w_drag / period - power) <= 1e-8 * power


def test_a_runs_sensitivities_are_richardson_differences_of_whole_runs():
    # 20 s: long enough that the frequency's sensitivities grow with t
    # (a difference of the drive's waveforms in its frequency errs by
    # (h t)^2 / 6: what the Rust harness caught)
    tight = dict(integrator="dop853", rtol=1e-12, atol=1e-12, formulation="dae", t_end=20.0, every=20.0)
    scene = rotor_drive()
    names, columns = ["psi.omega", "drag.c"], ["x", "y", "phi", "xd", "phid"]
    s = ezy.sensitivity(scene, wrt=names, **tight)
    assert s["t"].iloc[-1] == 20.0
    for name, p in [("psi.omega", 3.0), ("drag.c", 0.5)]:
        got = np.array([s[f"d{c}/d{name}"].iloc[-1] for c in columns])
        scale = np.max(np.abs(got))

        def end(v):
            r = ezy.run(scene, set={name: v}, **tight)
            return np.array([r[c][-1] for c in columns])

        # h = 1e-4 max(1, |p|), extrapolated twice from h, h/2, h/4 (the
        # h^2, then the h^4 term removed: one extrapolation left 1.4e-6 of
        # the largest in the frequency, whose lever t h grows with the run)
        h = 1e-4 * max(1.0, abs(p))
        d1, d2, d3 = [(end(p + k) - end(p - k)) / (2 * k) for k in (h, h / 2, h / 4)]
        r1, r2 = d2 + (d2 - d1) / 3, d3 + (d3 - d2) / 3
        want = r2 + (r2 - r1) / 15
        oracle = np.max(np.abs(want - r2))
        for c, g, w in zip(columns, got, want):
            print(f"d{c}/d{name}: {g:.12e} against {w:.12e} ({abs(g - w) / scale:.1e} of the largest)")
        print(f"d/d{name}: Richardson change {oracle:.1e}, largest sensitivity {scale:.3e}")
        # the differences settled: their last change below 1e-6 of the
        # largest
        assert oracle <= 1e-6 * scale, (name, oracle, scale)
        # 1e-7 of the largest sensitivity: the runs' error control at
        # 1e-12 over the smallest step 2 (h/4) = 5e-5 is ~2e-8 of a state
        # of size 1 (the runs at nearby p take nearly the same steps, and
        # the agreement measured 1e-10); plus three times the oracle's own
        # change
        assert np.all(np.abs(got - want) <= 1e-7 * scale + 3 * oracle), (name, got, want)


def test_an_optimum_is_the_best_of_a_local_scan_and_its_multiplier_the_differences():
    budget = 0.3
    o = ezy.optimize(
        "drive-rolling-resistance",
        maximize="gait.mean_speed",
        over={"motor.omega": (0.5, 8.0)},
        subject_to="gait.mean_power <= 0.3",
    )
    w, v, pw = o["motor.omega"][0], o["gait.mean_speed"][0], o["gait.mean_power"][0]
    report = o.attrs["report"]
    print(report)
    # the optimum the Rust harness finds (tests/oracle/optimize.rs),
    # 2.681809: where the power meets the budget, dP/domega = -0.165, so
    # the budget met to 1e-6 places omega to 2e-6; 1e-5 with the six
    # digits' rounding
    assert abs(w - 2.68181) <= 1e-5
    assert "converged" in report and "first-order (KKT) conditions hold" in report
    mu = float(re.search(r"binding: gait\.mean_power <= 0\.3 \(multiplier ([-0-9.e]+)\)", report).group(1))
    # the budget is binding, at its bound to 1e-6 (the optimizer's
    # constraint tolerance; it gave 9e-11)
    assert abs(pw - budget) <= 1e-6 * budget

    def at(omega):
        r = gait("drive-rolling-resistance", set={"motor.omega": omega})
        return r["mean_speed"], r["mean_power"]

    # a scan of +-0.02 rad/s by separate analyses: no feasible point
    # faster. Feasible: the budget to 1e-9 (the gaits' Newton tolerance);
    # faster: by more than 1e-9. A step of 0.005 rad/s moves the speed
    # by ~5e-4 and the power by ~1e-3, far above either.
    for omega in w + np.linspace(-0.02, 0.02, 9):
        speed, power = at(omega)
        print(f"omega {omega:.6f}: speed {speed:.10f}, power {power:.10f}")
        assert not (power <= budget + 1e-9 and speed > v + 1e-9), (omega, speed, power)
    # the multiplier: mu = (dv/domega) / (dP/domega) at the optimum, by
    # central differences of gaits at h = 1e-3 and 5e-4, extrapolated; to
    # 2e-5 relative (the gaits' noise 1e-9 over 2h = 1e-3 is ~1e-6 of
    # dv/domega ~ 0.1, with the optimum's own error in omega) or three
    # times the extrapolation's change, whichever is larger
    def ratio(h):
        (v1, p1), (v0, p0) = at(w + h), at(w - h)
        return (v1 - v0) / (p1 - p0)

    r1, r2 = ratio(1e-3), ratio(5e-4)
    want = r2 + (r2 - r1) / 3
    print(f"multiplier {mu} against the differences' {want} (change {abs(want - r2):.1e})")
    assert want > 0
    assert abs(mu - want) <= max(2e-5 * want, 3 * abs(want - r2)), (mu, want)


# Ctrl-C during each long call that test_ezy.py does not already stop (it
# stops ezy.run, ezy.check and a model's derivation): SIGINT 0.5 s into
# the call, KeyboardInterrupt within a second. Each call takes 3 to 20 s
# here unless stopped (timed on 2 cores), so the signal lands inside it.

LONG_CALLS = {
    # 200 gaits along the branch (10 s)
    "analyze-continue": lambda: ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.5:3:200"),
    # sensitivities in two parameters over 200 s (20 s)
    "sensitivity": lambda: ezy.sensitivity("drive", wrt=["M0", "omega"], t_end=200.0, every=10.0),
    # a grid of 101 gaits before the search (3 s of one core)
    "optimize": lambda: ezy.optimize(
        "drive-rolling-resistance", maximize="gait.mean_speed", over={"motor.omega": (0.5, 8.0)}, grid=101
    ),
    # 40 runs of 60 s one after another (15 s)
    "sweep": lambda: ezy.sweep("drive", {"M0": "1:3:40"}, jobs=1),
}


@pytest.mark.parametrize("call", sorted(LONG_CALLS))
def test_ctrl_c_stops_each_long_call_within_a_second(sigint_raises, call):
    took = interrupted_after(0.5, LONG_CALLS[call])
    print(f"{call}: KeyboardInterrupt {took:.3f} s after SIGINT")
    # the commands poll their stop flag between steps, gaits and runs
    # (each well under 0.1 s) and the binding polls Python's signals
    # every 10 ms: a second is ten times that, for a loaded machine
    assert took < 1.0, took
    # and the module works afterwards (the stop request was cleared)
    assert ezy.run("drive", t_end=0.1).data.shape[0] > 1


def test_ctrl_c_stops_a_fit_within_a_second(sigint_raises):
    truth = {"rolling_A.damping": 1.3, "motor.amplitude": 2.4}
    data = ezy.run("drive-rolling-resistance", set=truth, t_end=2000.0, every=0.1).to_pandas()[["t", "x1", "y1"]]
    # 8 runs of 2000 s with their sensitivities from the scene's values
    # (6 s here unless stopped)
    took = interrupted_after(
        0.5,
        ezy.fit,
        "drive-rolling-resistance",
        data=data,
        columns=["x1", "y1"],
        over={"rolling_A.damping": (0.0, 5.0), "motor.amplitude": (1.0, 3.0)},
        rtol=1e-12,
        atol=1e-12,
    )
    print(f"fit: KeyboardInterrupt {took:.3f} s after SIGINT")
    assert took < 1.0, took


def test_two_threads_give_the_serial_calls_numbers():
    # the gait's derivatives and a run's sensitivities of the typed model
    scene = rotor_drive()
    # some 0.4 s a call on one core: long enough to see the two overlap
    tight = dict(integrator="dop853", rtol=1e-12, atol=1e-12, t_end=600.0, every=1.0)

    def call():
        return ezy.sensitivity(scene, wrt=["psi.omega", "drag.c"], **tight).to_numpy()

    serial = call()
    start = time.monotonic()
    again = call()
    one = time.monotonic() - start  # the second: the first warms caches
    # the same call twice: the same numbers to the bit
    assert np.array_equal(serial, again)
    results = [None, None]

    def worker(k):
        results[k] = call()

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(2)]
    start = time.monotonic()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    both = time.monotonic() - start
    # timing is the benchmarks' (a loaded CI machine); printed, not asserted:
    # below 2x of one call means the two overlapped (the GIL released)
    print(f"one call {one:.3f} s, two in two threads {both:.3f} s ({both / one:.2f}x)")
    # both finished, each with the serial call's numbers to the bit
    for r in results:
        assert r is not None and np.array_equal(r, serial)
    # and a gait, likewise
    g = ezy.analyze(scene, wrt="psi.omega").periodic
    gaits = [None, None]

    def analyzer(k):
        gaits[k] = ezy.analyze(scene, wrt="psi.omega").periodic

    threads = [threading.Thread(target=analyzer, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for p in gaits:
        assert p is not None and p.equals(g)
