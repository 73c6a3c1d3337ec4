"""The `ezy` Python package against the `ezy` command line of the same build.

Run by `cargo test` (python/tests/pytest.rs), which puts the freshly built
module on PYTHONPATH and the command line's directory in EZY_BIN_DIR.
"""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import ezy

BIN = Path(os.environ["EZY_BIN_DIR"]) / "ezy"
WORKSPACE = Path(os.environ["EZY_WORKSPACE"])


def cli(*args, cwd=None):
    """Runs the command line; returns (exit status, stdout, stderr)."""
    p = subprocess.run([str(BIN), *args], capture_output=True, text=True, cwd=cwd)
    return p.returncode, p.stdout, p.stderr


def cli_error(*args, cwd=None):
    """The command line's error message (its stderr without `error: `)."""
    code, _, err = cli(*args, cwd=cwd)
    assert code != 0, args
    assert err.startswith("error: "), err
    return err[len("error: ") :].strip()


def trajectory(out):
    """trajectory.csv as (columns, 2-D array)."""
    path = Path(out) / "trajectory.csv"
    with open(path) as f:
        columns = f.readline().strip().split(",")
    return columns, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


RUN = dict(integrator="dop853", rtol=1e-11, every=0.5, t_end=10.0)
FLAGS = ["--integrator", "dop853", "--rtol", "1e-11", "--every", "0.5", "--t-end", "10"]


def test_models_and_scenes_are_the_command_lines():
    models = ezy.models()
    assert "ezyroller" in models and models["ezyroller"]
    scenes = ezy.scenes()
    assert "drive" in scenes and "four-bar" in scenes
    _, listing, _ = cli("list")
    for name in scenes:
        assert f"  {name} " in listing
    for key in models:
        assert f"  {key} " in listing


def test_effect_kinds_are_the_registry_s():
    kinds = ezy.effect_kinds()
    assert list(kinds)[:4] == ["hinge-motor", "hinge-spring", "hinge-damper", "hinge-servo"]
    assert all(k["builtin"] for k in kinds.values())
    damper = kinds["hinge-damper"]
    assert "`damping`" in damper["keys"] and damper["value_column"] == "tau_<name>"
    assert kinds["rolling-viscous"]["value_column"] == "F_<name>"


def test_a_run_equals_the_command_line_to_the_last_digit(tmp_path):
    r = ezy.run("drive", **RUN)
    code, _, err = cli("run", "drive", *FLAGS, "--no-figures", "--out", str(tmp_path))
    assert code == 0, err
    columns, table = trajectory(tmp_path)
    assert r.columns == columns
    # the CSV holds each number's shortest round-trip decimal: parsed back,
    # it is the same double, so the arrays are equal bit for bit
    assert r.data.shape == table.shape == (21, len(columns))
    assert np.array_equal(r.data, table)
    # the summary's final state line is the command line's
    final = [l for l in r.summary.splitlines() if "final state" in l]
    code, out, _ = cli("run", "drive", *FLAGS, "--no-figures", "--out", str(tmp_path / "again"))
    assert final and final[0] in out


def test_arrays_are_float64_views_of_one_table():
    r = ezy.run("drive", **RUN)
    assert r.data.dtype == np.float64 and r.data.ndim == 2
    assert r.data.flags["C_CONTIGUOUS"]
    t, x1 = r.t, r["x1"]
    assert t.shape == x1.shape == (r.data.shape[0],)
    assert np.shares_memory(t, r.data) and np.shares_memory(x1, r.data)
    assert t[0] == 0.0 and t[-1] == 10.0 and np.all(np.diff(t) == 0.5)
    assert "x1" in r and "nonsense" not in r and len(r) == r.data.shape[0] == len(t)
    with pytest.raises(KeyError, match="no column `nonsense`.*its columns: t, x1"):
        r["nonsense"]
    df = r.to_pandas()
    assert list(df.columns) == r.columns and df.shape == r.data.shape
    assert np.array_equal(df["phi2"].to_numpy(), r["phi2"])
    assert r.stats["method"] == "dop853" and r.stats["steps"] > 0
    assert r.stats["rhs_evals"] >= r.stats["steps"]
    assert "drive" in repr(r) and "21 rows" in repr(r)


def test_errors_carry_the_command_lines_messages(tmp_path):
    with pytest.raises(ezy.EzyError) as e:
        ezy.run("no-such-scene")
    assert str(e.value) == cli_error("run", "no-such-scene")
    with pytest.raises(ezy.EzyError) as e:
        ezy.run("drive", set={"motor.bogus": 1.0})
    assert str(e.value) == cli_error("run", "drive", "--set", "motor.bogus=1", "--out", str(tmp_path / "x"))
    with pytest.raises(ezy.EzyError, match="rtol"):
        ezy.run("drive", rtol=-1.0)
    with pytest.raises(TypeError, match="unexpected keyword `rtl`; its settings: set, integrator"):
        ezy.run("drive", rtl=1e-9)
    with pytest.raises(TypeError, match=r"run\(\): `rtol` must be a number, not str \(tight\)"):
        ezy.run("drive", rtol="tight")
    with pytest.raises(TypeError, match="`t_end` must be a number, not bool"):
        ezy.run("drive", t_end=True)
    with pytest.raises(ezy.EzyError, match='integrator="rk5".*rk4'):
        ezy.run("drive", integrator="rk5")
    # a bad scene file: the file, line and key, as the command line says
    bad = tmp_path / "bad.toml"
    text = (WORKSPACE / "models" / "scenes" / "sleigh.toml").read_text()
    bad.write_text(text.replace("t_end = ", "t_end = -", 1))
    with pytest.raises(ezy.EzyError) as e:
        ezy.run(str(bad))
    assert str(e.value) == cli_error("run", str(bad))
    assert "bad.toml" in str(e.value) and "t_end" in str(e.value)
    with pytest.raises(ezy.EzyError) as e:
        ezy.equations("no-such-model")
    assert str(e.value) == cli_error("equations", "no-such-model")


def test_a_scene_object_changes_what_set_changes(tmp_path):
    s = ezy.scene("drive")
    assert s.name == "drive" and s.model == "ezyroller"
    motor = s.effects["motor"]
    assert motor.amplitude == 2.0 and s["M0"] == 2.0
    motor.amplitude = 1.0
    assert motor.amplitude == 1.0 and s.sets == [("motor.amplitude", 1.0)]
    assert motor.numbers()["torque.cos.amplitude"] == 1.0
    r = s.run(**RUN)
    code, _, err = cli("run", "drive", *FLAGS, "--set", "motor.amplitude=1", "--no-figures", "--out", str(tmp_path))
    assert code == 0, err
    _, table = trajectory(tmp_path)
    assert np.array_equal(r.data, table)
    # a scene parameter moves every number bound to it
    s2 = ezy.scene("drive")
    s2["M0"] = 0.5
    assert s2.effects["motor"].amplitude == 0.5 and s2.params["M0"] == 0.5
    assert np.array_equal(ezy.run(s2, **RUN).data, ezy.run("drive", set={"M0": 0.5}, **RUN).data)
    # refused at once, with the command line's message
    with pytest.raises(ezy.EzyError) as e:
        s2.effects["motor"].bogus = 1.0
    assert str(e.value) == cli_error("run", "drive", "--set", "motor.bogus=1", "--out", str(tmp_path / "y"))
    with pytest.raises(ezy.EzyError, match="finite"):
        s2["M0"] = float("nan")
    with pytest.raises(AttributeError, match="its numbers: torque.cos.amplitude"):
        s2.effects["motor"].bogus
    assert s2.sets == [("M0", 0.5)]


@pytest.fixture
def sigint_raises():
    """SIGINT raises KeyboardInterrupt in this process while the test runs.

    Python installs that handler only if it started with SIGINT at its
    default action. A process started with SIGINT ignored (a background job
    of a shell without job control: `cargo test ... &` in a script) keeps
    ignoring it: no SIGINT would reach the run, which then went to its end
    ("DID NOT RAISE KeyboardInterrupt", issue 64).
    """
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def run_signalled(events, *args, **settings):
    """`ezy.run(*args, **settings)`, with SIGINT sent to this process while
    the main thread is inside the call with the GIL released (in the run's
    setup or steps), whatever the machine's load.

    A thread sends it once the profiler has seen the call begin and not end,
    and the main thread's innermost Python frame is this function's: while
    the sending thread holds the GIL, that means the main thread is in the
    run. `events` receives the profiler's events of the call: c_call, then
    c_exception (it raised) or c_return.
    """
    run, main, here = ezy.run, threading.get_ident(), sys._getframe().f_code

    def profile(frame, event, arg):
        if arg is run and event.startswith("c_"):
            events.append(event)

    def interrupt():
        while events != ["c_call"] or sys._current_frames()[main].f_code is not here:
            if len(events) > 1:
                return  # the call ended unsignalled
            time.sleep(0.001)
        os.kill(os.getpid(), signal.SIGINT)

    sender = threading.Thread(target=interrupt)
    sender.start()
    sys.setprofile(profile)
    try:
        return run(*args, **settings)
    finally:
        sys.setprofile(None)
        sender.join()


def test_ctrl_c_stops_a_run_at_its_next_step(sigint_raises):
    events = []
    with pytest.raises(KeyboardInterrupt):
        # 6e7 RK4 steps (15 s here, a minute under load) unless stopped
        run_signalled(events, "drive", integrator="rk4", dt=1e-5, t_end=600.0, every=10.0)
    # ezy.run raised it (["c_call"] alone: the run went to its end without
    # seeing the signal, and Python raised it after the call)
    assert events == ["c_call", "c_exception"], events
    # and the module runs again afterwards
    assert ezy.run("drive", **RUN).data.shape[0] == 21


def test_a_first_run_calls_no_python_code():
    # Python code inside ezy.run (outside its signal polls) is where a
    # Ctrl-C would be raised out of place: NumPy's version check, run by the
    # first result of a process, turned it into a PanicException ("Failed to
    # access NumPy array API capsule"). A fresh process, its first run:
    script = """if 1:
        import gc, sys, ezy
        gc.disable()
        inside, calls = [], []
        def profile(frame, event, arg):
            if arg is ezy.run:
                inside.append(event)
            elif event == "call" and inside == ["c_call"]:
                calls.append(f"{frame.f_code.co_filename}:{frame.f_code.co_name}")
        sys.setprofile(profile)
        ezy.run("drive", t_end=0.1)
        sys.setprofile(None)
        assert inside == ["c_call", "c_return"], inside
        print(calls)
    """
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"


def test_the_output_budget_an_error_advises_can_be_passed():
    with pytest.raises(ezy.EzyError, match="max.output.mb") as e:
        ezy.run("drive", integrator="dop853", every=1e-6, t_end=60.0)
    assert "MB of output" in str(e.value)
    with pytest.raises(ezy.EzyError, match="MB of output"):
        ezy.run("drive", every=0.001, t_end=60.0, max_output_mb=0.01)
    assert ezy.run("drive", every=0.1, t_end=1.0, max_output_mb=1.0).data.shape[0] == 11
    with pytest.raises(ValueError, match="max_output_mb"):
        ezy.run("drive", max_output_mb=float("nan"))


def test_a_sweep_is_a_dataframe_of_the_runs():
    df = ezy.sweep("drive", {"M0": [1.0, 2.0, 3.0]}, metrics=["final(T)"], jobs=1, **RUN)
    assert list(df["M0"]) == [1.0, 2.0, 3.0] and list(df["status"]) == ["ok"] * 3
    for m0, final_t in zip(df["M0"], df["final(T)"]):
        r = ezy.run("drive", set={"M0": m0}, **RUN)
        assert final_t == r["T"][-1]
    grid = ezy.sweep(ezy.scene("drive").set("omega", 2.0), {"M0": "1:2:3"}, jobs=2, **RUN)
    assert list(grid["M0"]) == [1.0, 1.5, 2.0]
    # a parameter the scene object set is swept: the grid overrides it
    s = ezy.scene("drive")
    s["M0"] = 3.0
    swept = ezy.sweep(s, {"M0": [1.0, 2.0]}, metrics=["final(T)"], jobs=1, **RUN)
    assert list(swept["final(T)"]) == list(df["final(T)"][:2])
    # and unset: the scene file's number again
    del s["M0"]
    assert s.sets == [] and s["M0"] == 2.0
    with pytest.raises(KeyError, match="`M0` was not set on scene drive; set on it: nothing"):
        del s["M0"]
    with pytest.raises(ezy.EzyError, match="`grid=` `M0=1:2`: expected NAME=START:STOP:COUNT"):
        ezy.sweep("drive", {"M0": "1:2"}, **RUN)
    with pytest.raises(ezy.EzyError, match="grid"):
        ezy.sweep("drive", {}, **RUN)


def test_equations_render_as_latex_and_text():
    e = ezy.equations("ezyroller")
    latex = e._repr_latex_()
    assert "\\begin{align*}" in latex and "\\documentclass" not in latex
    assert "\\gamma_{\\text{A}}" in latex
    _, text, _ = cli("equations", "ezyroller")
    assert str(e) == text
    assert ezy.equations("snake", set={"N": 3}).text != ezy.equations("snake", set={"N": 4}).text
    # a count the model cannot be set up at is an error, not an abort of
    # the interpreter (it allocated 13 GB and aborted)
    with pytest.raises(ezy.EzyError, match="3000000 generalized coordinates"):
        ezy.equations("snake", set={"N": 1000000})


def test_check_passes_for_a_built_in_model():
    c = ezy.check("ezyroller", states=2, seed=3)
    assert c.passed and bool(c) and "ezyroller" in c.table.lower()


def test_figures_are_drawn_only_when_asked():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = ezy.run("drive", **RUN)
    assert r.figures[:2] == ["fig3_paths", "fig4_speed"]
    fig = r.plot("fig3_paths")
    assert len(fig.axes) == 1 and fig.axes[0].get_title().startswith("Paths")
    labels = [l.get_label() for l in fig.axes[0].get_lines()]
    assert "point A" in labels and "point C" in labels
    xs = [l for l in fig.axes[0].get_lines() if l.get_label() == "point A"][0].get_xdata()
    assert np.array_equal(xs, r["A.x"])
    fig4 = r.plot("fig4_speed.png")
    assert len(fig4.axes) == 2
    with pytest.raises(KeyError, match="its figures: fig3_paths"):
        r.plot("fig99")
    plt.close("all")


def test_the_guides_notebook_runs(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nb = json.loads((WORKSPACE / "docs" / "book" / "src" / "python.ipynb").read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert len(code) >= 5
    scope = {}
    # as Jupyter runs it: from the notebook's directory
    here, argv = os.getcwd(), list(sys.argv)
    os.chdir(WORKSPACE / "docs" / "book" / "src")
    try:
        for cell in code:
            exec(compile("".join(cell["source"]), "python.ipynb", "exec"), scope)
    finally:
        os.chdir(here)
        sys.argv = argv
    assert set(scope["sweep"]["M0"]) and scope["result"].data.shape[0] > 1000
    # the gait's tools on the Roller Racer: the numbers the guide quotes
    assert scope["fitted"].loc["roll_A.damping", "estimate"] == pytest.approx(7.0, abs=1e-6)
    assert scope["best"]["steer.omega"][0] == pytest.approx(2.40, abs=0.005)
    assert scope["best"]["gait.mean_power"][0] == pytest.approx(2.0, abs=1e-6)
    assert len(scope["branch"]) == 5 and len(scope["geo"].gait_path) > 10
    assert scope["derivatives"].periodic["dmean_speed/dsteer.amplitude"][0] == pytest.approx(0.99, abs=0.005)
    plt.close("all")
    # the guide's page shows the same cells, in order
    page = (WORKSPACE / "docs" / "book" / "src" / "python.md").read_text()
    shown = page.split("## The notebook", 1)[1].split("```python\n")[1:]
    shown = [b.split("```", 1)[0].rstrip("\n") for b in shown]
    assert shown == ["".join(c["source"]).rstrip("\n") for c in code]


def roller_racer_text():
    """The Roller Racer's model text, as the example crate's `model!` has it."""
    src = (WORKSPACE / "examples/roller-racer/src/lib.rs").read_text()
    body = src[src.index("model! {") + len("model! {"):]
    depth, end = 1, 0
    for end, ch in enumerate(body):
        depth += {"{": 1, "}": -1}.get(ch, 0)
        if depth == 0:
            break
    return body[:end]


def test_a_vehicle_defined_from_text_runs_sweeps_and_checks(tmp_path):
    text = roller_racer_text()
    m = ezy.Model(text)
    assert (m.name, m.key) == ("RollerRacer", "RollerRacer")
    assert m.coords == ["x1", "y1", "phi1", "x2", "y2", "phi2"]
    assert m.params["d1"] == 0.6 and "nq = 6" in repr(m)
    scene = WORKSPACE / "examples/roller-racer/scenes/roller.toml"
    r = ezy.run(str(scene), model=m, t_end=2.0)
    # the command line on the same text as a model file: the same table
    (tmp_path / "racer.ezy").write_text(text)
    toml = scene.read_text().replace('model = "roller_racer"', 'model = "racer.ezy"')
    (tmp_path / "racer.toml").write_text(toml)
    code, _, err = cli("run", str(tmp_path / "racer.toml"), "--t-end", "2", "--no-figures", "--out", str(tmp_path / "out"))
    assert code == 0, err
    columns, table = trajectory(tmp_path / "out")
    assert r.columns == columns and np.array_equal(r.data, table)
    assert r["x1"][-1] > 0.1  # the swinging handlebar drives it forward
    # a sweep of a parameter, and the same file loaded
    df = ezy.sweep(str(scene), {"d1": [0.5, 0.7]}, model=m, metrics=["final(x1)"], jobs=1, t_end=1.0)
    assert list(df["status"]) == ["ok", "ok"] and df["final(x1)"].iloc[0] != df["final(x1)"].iloc[1]
    loaded = ezy.Model.load(tmp_path / "racer.ezy", key="racer")
    assert loaded.key == "racer" and str(loaded.equations()) == str(m.equations())
    assert "J.x" in str(ezy.equations(m)) and ezy.check(m, states=2)
    # a scene whose names the model lacks is refused at its key
    with pytest.raises(ezy.EzyError, match="drive.toml.*hinge"):
        ezy.run("drive", model=m)


def test_a_mistake_in_a_model_text_is_located(tmp_path):
    text = roller_racer_text().replace("point C on front", "point C on wheel")
    line = next(i for i, l in enumerate(text.splitlines(), 1) if "on wheel" in l)
    with pytest.raises(ezy.EzyError, match=rf"line {line}, column \d+: point `C` refers to unknown body `wheel`"):
        ezy.Model(text)
    (tmp_path / "bad.ezy").write_text(text)
    with pytest.raises(ezy.EzyError, match=rf"bad.ezy:{line}:\d+: point `C` refers to unknown body `wheel`"):
        ezy.Model.load(tmp_path / "bad.ezy")
    with pytest.raises(ezy.EzyError, match="cannot read model file"):
        ezy.Model.load(tmp_path / "missing.ezy")


def racer_gait_keys():
    """The Roller Racer's gait scene as a scene file's keys: the handlebar
    swung, viscous rolling resistance at both axles."""
    return dict(
        name="racer-gait",
        t_end=60.0,
        initial={"q": {"x1": 0.0, "y1": 0.0, "phi1": 0.0}, "qd": {"x1": 0.0}},
        integrator={"method": "dop853", "rtol": 1e-10, "atol": 1e-10},
        drives={"steer": {"angle": {"sin": {"amplitude": 0.5, "omega": 2.0}}}},
        effects={
            "roll_A": {"kind": "rolling-viscous", "skate": "A", "damping": 5.0},
            "roll_C": {"kind": "rolling-viscous", "skate": "C", "damping": 5.0},
        },
    )


def test_a_notebook_user_defines_the_roller_racer_runs_sweeps_and_finds_its_gait(tmp_path):
    racer = ezy.Model(roller_racer_text())
    scene = ezy.scene(model=racer, **racer_gait_keys())
    assert scene.model == "RollerRacer" and scene["d1"] == 0.6
    r = scene.run()
    # a result behaves as a table: rows, iteration, an array, units
    assert len(r) == r.data.shape[0] == 6001 and np.asarray(r).shape == r.data.shape
    assert np.array_equal(next(iter(r)), r.data[0]) and np.array_equal(list(r)[-1], r.data[-1])
    assert (r.units["t"], r.units["x1d"], r.units["phi1"]) == ("s", "m/s", "rad")
    assert "rate: x of the centre of mass of `main`" in r.describe()
    # a sweep of the damping: more resistance, less distance
    df = ezy.sweep(scene, {"roll_A.damping": [2.0, 8.0]}, metrics=["final(x1)"], jobs=1, t_end=10.0)
    assert list(df["status"]) == ["ok", "ok"] and df["final(x1)"].iloc[0] > df["final(x1)"].iloc[1]
    # its gait: the forcing's period, stable, at a mean speed of 0.27 m/s
    gait = ezy.analyze(scene)
    p = gait.periodic
    assert p["period"].iloc[0] == pytest.approx(np.pi, rel=1e-12) and p["stability"].iloc[0] == "stable"
    assert 0.26 < p["mean_speed"].iloc[0] < 0.28 and gait.equilibria is None
    # the command line on the same text and scene as files: the same gait
    (tmp_path / "racer.ezy").write_text(roller_racer_text())
    (tmp_path / "gait.toml").write_text(
        ezy_scene_toml(dict(racer_gait_keys(), model=str(tmp_path / "racer.ezy"), description="the gait"))
    )
    code, _, err = cli("analyze", str(tmp_path / "gait.toml"), "--no-figures", "--out", str(tmp_path / "a"))
    assert code == 0, err
    import pandas as pd

    cli_p = pd.read_csv(tmp_path / "a" / "periodic.csv")
    assert cli_p["mean_speed"].iloc[0] == p["mean_speed"].iloc[0]
    # a scene file's text with the model given, and a linearization
    same = ezy.scene(toml=(tmp_path / "gait.toml").read_text(), model=racer)
    assert np.array_equal(same.run(t_end=1.0).data, scene.run(t_end=1.0).data)
    lin = ezy.linearize(scene, at=1.0)
    assert lin.A.shape == (12, 12) and lin.eigenvalues.dtype == np.complex128 and "x1" in lin.state
    # a value TOML cannot hold, or nothing to build from, is a TypeError
    with pytest.raises(TypeError, match="`initial.q.x1` must be a number"):
        ezy.scene(model=racer, **dict(racer_gait_keys(), initial={"q": {"x1": object()}}))
    with pytest.raises(TypeError, match="give a scene's name, toml=TEXT, or the scene's keys"):
        ezy.scene()
    with pytest.raises(TypeError, match="made from keywords needs `model=`"):
        ezy.scene("drive", t_end=5.0)
    with pytest.raises(TypeError, match=r"analyze\(\): `period` must be a number, not str"):
        ezy.analyze(scene, period="pi")
    with pytest.raises(TypeError, match=r"linearize\(\): `at` must be a number, not str"):
        ezy.linearize(scene, at="1")
    with pytest.raises(ezy.EzyError, match=r"^scene\(\): `initial.q.x1`: x1 = inf must be finite$"):
        ezy.scene(model=racer, **dict(racer_gait_keys(), initial={"q": {"x1": float("inf")}}))
    with pytest.raises(ezy.EzyError, match="effects.r.*`Z`"):
        ezy.scene(model=racer, **dict(racer_gait_keys(), effects={"r": {"kind": "rolling-viscous", "skate": "Z", "damping": 1.0}}))


def ezy_scene_toml(keys):
    """A scene file's text from its keys (the TOML that ezy.scene writes)."""
    lines = []

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(float(v)) if isinstance(v, float) else str(v)
        if isinstance(v, str):
            return '"' + v + '"'
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        raise TypeError(v)

    for k, v in keys.items():
        if not isinstance(v, dict):
            lines.append(f"{k} = {value(v)}")
    for k, v in keys.items():
        if isinstance(v, dict):
            for sub, x in v.items():
                if isinstance(x, dict) and k in ("drives", "effects"):
                    lines.append(f"[{k}.{sub}]")
                    lines.extend(f"{kk} = {value(xx)}" for kk, xx in x.items())
            if k not in ("drives", "effects"):
                lines.append(f"[{k}]")
                lines.extend(f"{kk} = {value(xx)}" for kk, xx in v.items())
    return "\n".join(lines) + "\n"


def test_the_stub_names_everything_the_module_offers():
    import ast

    stub = ast.parse((WORKSPACE / "python" / "ezy.pyi").read_text())
    named = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    named |= {t.id for n in stub.body if isinstance(n, ast.AnnAssign) for t in [n.target]}
    named = {n for n in named if not n.startswith("_")}
    offered = {n for n in dir(ezy) if not n.startswith("_")}
    assert named == offered, (offered - named, named - offered)
    # each class: every attribute, method and protocol it has, and no more
    classes = {n.name: n for n in stub.body if isinstance(n, ast.ClassDef)}
    functions = {n.name: n for n in stub.body if isinstance(n, ast.FunctionDef)}
    protocol = {"__getitem__", "__setitem__", "__delitem__", "__contains__", "__len__", "__iter__", "__array__", "__bool__"}
    for name, node in classes.items():
        real = getattr(ezy, name)
        if name == "EzyError":
            continue
        has = {k for k in vars(real) if not (k.startswith("__") and k.endswith("__")) or k in protocol}
        if name == "Toolkit":
            # its methods are the module's functions, which the stub lists
            assert has == set(functions), (name, has ^ set(functions))
            continue
        stubbed = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
        stubbed |= {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
        stubbed = {k for k in stubbed if k in protocol or not (k.startswith("__") and k.endswith("__"))}
        assert has == stubbed, (name, "missing from the stub:", has - stubbed, "not in the module:", stubbed - has)
    # each function and method: the keywords it takes, in the stub too
    import inspect

    def keywords(node):
        a = node.args
        return {x.arg for x in a.posonlyargs + a.args + a.kwonlyargs} - {"self"}

    for name, node in functions.items():
        real = inspect.signature(getattr(ezy, name)).parameters.values()
        named = {p.name for p in real if p.kind != p.VAR_KEYWORD}
        assert named <= keywords(node), (name, named - keywords(node))
    # the keys of `tables` the stub's docstrings name: every one written
    import re

    def documented(cls):
        body = classes[cls].body
        at = [i for i, n in enumerate(body) if isinstance(n, ast.AnnAssign) and n.target.id == "tables"][0]
        return set(re.findall(r'"(\w+)"', body[at + 1].value.value))

    written = set()
    for a in [ezy.analyze("sleigh"), ezy.analyze("drive", t_end=30.0), ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.5:1:3")]:
        written |= set(a.tables)
    assert written == documented("Analysis") == {"periodic", "equilibria", "branch", "growth"}
    written = set()
    for g in [ezy.geometry("kinematic-snake", grid=5), ezy.geometry(ezy.Model(roller_racer_text()), grid=5, range=(-1.0, 1.0))]:
        written |= set(g.tables)
        assert all(getattr(g, k) is g.tables[k] for k in g.tables)
    assert written == documented("Geometry") == {"connection", "curvature", "momentum", "gait", "gait_path"}


def test_the_geometry_of_a_built_in_snake_and_of_a_users_racer():
    # the scene: its gait reconstructed from the connection and simulated
    g = ezy.geometry("kinematic-snake", grid=11)
    rows = g.gait.set_index("method")
    assert abs(rows.loc["reconstructed", "dx"] - rows.loc["simulated", "dx"]) < 1e-8
    assert list(g.curvature.columns) == ["alpha1", "alpha2", "DA_x_alpha1_alpha2", "DA_y_alpha1_alpha2", "DA_theta_alpha1_alpha2"]
    # the model at one shape: the command line's numbers
    a = ezy.geometry("kinematic_snake", at={"alpha1": 0.5, "alpha2": -0.3})
    assert len(a.connection) == 1 and abs(a.connection["A_u_alpha1"].iloc[0] - 0.6551410853150368) < 1e-12
    # a user's model read from text: a mixed system, its momentum equation
    r = ezy.geometry(ezy.Model(roller_racer_text()), grid=9, range=(-1.0, 1.0))
    assert "mixed: 1 momentum component(s) p_u" in r.report and len(r.momentum) == 9
    with pytest.raises(ezy.EzyError, match="no symmetry under the plane's motions"):
        ezy.geometry("four-bar")


def test_sensitivities_of_a_run_and_of_a_gait(tmp_path):
    # a run's derivatives: the command line's numbers, as a DataFrame
    s = ezy.sensitivity("drive", wrt=["M0", "initial.q.phi2"], t_end=0.5)
    code, _, err = cli("sensitivity", "drive", "--wrt", "M0,initial.q.phi2", "--t-end", "0.5", "--out", str(tmp_path))
    assert code == 0, err
    with open(tmp_path / "sensitivity.csv") as f:
        columns = f.readline().strip().split(",")
    table = np.loadtxt(tmp_path / "sensitivity.csv", delimiter=",", skiprows=1, ndmin=2)
    assert list(s.columns) == columns and columns[:2] == ["t", "dx1/dM0"]
    assert np.array_equal(s.to_numpy(), table)
    assert "d/dM0 at M0 = 2" in s.attrs["report"]
    # a gait's derivatives: columns of .periodic
    a = ezy.analyze("drive-rolling-resistance", wrt="motor.omega")
    p = a.periodic
    assert p["dperiod/dmotor.omega"][0] == pytest.approx(-2.0 / np.pi, rel=1e-9)
    assert p["mean_power"][0] > 0 and p["efficiency"][0] > 0
    assert "dmean_speed/dmotor.omega" in p.columns
    # each column's unit and meaning, from the table of quantities
    text = a.describe()
    line = next(l for l in text.splitlines() if l.strip().startswith("drift_speed"))
    assert "[m/s]" in line and "does not depend on t0" in line, line
    assert "the reference body's frame at t0" in text
    assert a.units["periodic"]["drift_speed"] == "m/s" and a.units["periodic"]["dx_world"] == "m"
    assert a.units["periodic"]["dmean_speed/dmotor.omega"] == "the quantity's unit per the parameter's"
    assert s.attrs["units"]["dx1/dM0"] == "the state component's unit per the parameter's"
    assert "forward sensitivity" in s.attrs["description"]
    g = ezy.geometry("kinematic-snake", grid=5)
    assert g.units["gait"]["dx"] == "m" and "cycle's start" in g.describe()
    with pytest.raises(TypeError, match="wrt"):
        ezy.sensitivity("drive", wrt=3)
    with pytest.raises(ezy.EzyError, match="nope"):
        ezy.sensitivity("drive", wrt="nope", t_end=0.1)


def test_a_limit_cycle_and_a_located_bifurcation():
    # the four-bar's crank turns on a limit cycle, its period an unknown
    a = ezy.analyze("four-bar")
    p = a.periodic
    assert p["period"].iloc[0] == pytest.approx(0.7830006, abs=1e-6)
    assert p["turns_phi2"].iloc[0] == 1 and p["stability"].iloc[0] == "stable"
    assert "limit cycle (turns per period: phi2 1)" in a.report
    # the rolling-resistance gait's branch point: a row of its own in .branch
    b = ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.5:1:3").branch
    row = b[b["bifurcation"] == "branch point"]
    assert len(row) == 1 and len(b) == 4
    assert row["motor.amplitude"].iloc[0] == pytest.approx(0.6380639, abs=1e-6)
    assert row["critical_re"].iloc[0] == pytest.approx(1.0, abs=1e-6)


def test_switching_gives_the_whole_bifurcation_diagram():
    # the straight gait's pitchfork in the motor amplitude and its two
    # turning arms, as `ezy analyze --switch` finds them (checked against
    # runs in tests/switching.rs): one call, the branches as DataFrames
    a = ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.8:0.4:5", switch=True)
    d = a.diagram
    assert list(d["branch"]) == [0, 1, 2]
    assert list(d["bifurcation"].iloc[1:]) == ["pitchfork", "pitchfork"]
    assert list(d["criticality"].iloc[1:]) == ["supercritical", "supercritical"]
    assert all(d["symmetry_breaking"].iloc[1:])
    assert len(a.branches) == 3 and a.branches[0] is a.branch
    left, right = a.branches[1].iloc[-1], a.branches[2].iloc[-1]
    assert left["motor.amplitude"] == right["motor.amplitude"] == 0.4
    # mirror images: opposite turning at one speed (Newton's 1e-9)
    assert left["turning_rate"] == pytest.approx(-right["turning_rate"], abs=1e-8)
    assert abs(left["turning_rate"]) > 1e-2
    # (their speeds |displacement| / T differ: the mirror image is half a
    # forcing period on, and a turning gait's chord depends on its phase)
    assert left["mean_power"] == pytest.approx(right["mean_power"], rel=1e-8)
    assert ".branches[1], .branches[2]" in a.report and ".diagram" in a.report
    assert ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.8:0.4:5").diagram is None
    with pytest.raises(ValueError, match="switch=0"):
        ezy.analyze("drive", vary="M0=1:2:3", switch=0)
    with pytest.raises(TypeError, match="`switch`"):
        ezy.analyze("drive", vary="M0=1:2:3", switch="all")


def test_a_fit_from_a_dataframe_recovers_the_parameters(tmp_path):
    run = ezy.run(
        "drive-rolling-resistance",
        set={"rolling_A.damping": 1.3, "motor.amplitude": 2.4},
        t_end=4.0,
        every=0.1,
        rtol=1e-12,
        atol=1e-12,
    )
    data = run.to_pandas()[["t", "x1", "y1"]]
    f = ezy.fit(
        "drive-rolling-resistance",
        data=data,
        columns=["x1", "y1"],
        over={"rolling_A.damping": (0.0, 5.0), "motor.amplitude": (1.0, 3.0)},
        rtol=1e-12,
        atol=1e-12,
    )
    assert f.loc["rolling_A.damping", "estimate"] == pytest.approx(1.3, abs=1e-8)
    assert f.loc["motor.amplitude", "estimate"] == pytest.approx(2.4, abs=1e-8)
    assert "correlations" in f.attrs["report"]
    with pytest.raises(TypeError, match="over"):
        ezy.fit("drive-rolling-resistance", data=data, columns="x1", over={"motor.amplitude": 3})
    with pytest.raises(ezy.EzyError, match="outside the bounds"):
        ezy.fit("drive-rolling-resistance", data=data, columns="x1", over={"motor.amplitude": (3.0, 4.0)})


def test_an_optimization_gives_the_optimum_and_its_history(tmp_path):
    o = ezy.optimize(
        "drive-rolling-resistance",
        maximize="gait.mean_speed",
        over={"motor.omega": (0.5, 8.0)},
        subject_to=["gait.mean_power <= 1"],
        grid=0,
        out=tmp_path / "opt",
    )
    assert list(o.columns) == ["motor.omega", "gait.mean_speed", "gait.mean_power"]
    # the optimum the command line finds (tests/optimize.rs): 1.40872 rad/s
    assert o["motor.omega"][0] == pytest.approx(1.4087157, abs=1e-6)
    assert o["gait.mean_speed"][0] == pytest.approx(0.4691427, abs=1e-6)
    h = o.attrs["history"]
    assert h["motor.omega"].iloc[0] == pytest.approx(np.pi)
    assert "dgait.mean_speed/dmotor.omega" in h.columns
    assert "converged" in o.attrs["report"]
    assert (tmp_path / "opt" / "optimum.csv").exists()
    with pytest.raises(TypeError, match="one of"):
        ezy.optimize("drive-rolling-resistance", over={"motor.omega": (0.5, 8.0)})
    with pytest.raises(ezy.EzyError, match="gait.speed"):
        ezy.optimize("drive-rolling-resistance", maximize="gait.speed", over={"motor.omega": (0.5, 8.0)})


def test_an_objective_of_your_own_is_optimized_as_a_built_in_one():
    def final_x1(run):
        assert run.attrs["parameters"] == ["motor.omega"]
        return run["x1"].iloc[-1], [run["dx1/dmotor.omega"].iloc[-1]]

    kw = dict(over={"motor.omega": (1.0, 6.0)}, t_end=2.0, grid=0)
    own = ezy.optimize("drive", maximize=final_x1, **kw)
    built_in = ezy.optimize("drive", maximize="final(x1)", **kw)
    assert list(own.columns) == ["motor.omega", "final_x1"]
    # the same values and gradients: the same search, to the bit
    assert own["motor.omega"][0] == built_in["motor.omega"][0]
    assert own["final_x1"][0] == built_in["final(x1)"][0]
    with pytest.raises(ezy.EzyError, match="return \\(value"):
        ezy.optimize("drive", maximize=lambda run: "fast", **kw)


# issue 82: requests sized before the work, booleans refused, long calls
# that answer Ctrl-C


def interrupted_after(delay, function, *args, **kwargs):
    """Seconds from a SIGINT sent `delay` seconds into `function(*args,
    **kwargs)` (a call that takes far longer) to its KeyboardInterrupt."""
    sent = []

    def interrupt():
        time.sleep(delay)
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    sender = threading.Thread(target=interrupt)
    sender.start()
    try:
        function(*args, **kwargs)
    except KeyboardInterrupt:
        return time.monotonic() - sent[0]
    finally:
        sender.join()
    raise AssertionError("the call ended before the signal or without raising KeyboardInterrupt")


def test_a_sweep_is_sized_before_it_starts():
    start = time.monotonic()
    with pytest.raises(ezy.EzyError, match=r"`m` has 100000000000.*100000000000 runs.*1000000"):
        ezy.sweep("sleigh", {"m": "1:2:100000000000"})
    with pytest.raises(ezy.EzyError, match=r"`m` has 1000, `a` has 2000.*2000000 runs"):
        ezy.sweep("sleigh", {"m": "1:2:1000", "a": [0.1] * 2000})
    assert time.monotonic() - start < 1.0


def test_an_initial_heading_is_bounded_as_an_angle():
    toml = (WORKSPACE / "models/scenes/sleigh.toml").read_text()
    turned = []
    for v in ["0.5", "1e17", "1e33", "1e308"]:
        text = toml.replace("phi = 0.0 }", f"phi = {v} }}")
        if v == "0.5":
            r = ezy.run(ezy.scene(toml=text), t_end=1.0)
            turned.append(r["phi"][-1] - r["phi"][0])
            continue
        with pytest.raises(ezy.EzyError, match=rf"initial.q.phi.*{v}.*1e6"):
            ezy.scene(toml=text)
        with pytest.raises(ezy.EzyError, match=rf"initial.*phi.*{v}.*1e6"):
            ezy.scene(model="chaplygin_sleigh", t_end=1.0, initial={"q": {"phi": float(v)}, "qd": {"x": 1.0, "phi": 1.0}})
    assert abs(turned[0]) > 0.1


def test_booleans_are_not_numbers():
    with pytest.raises(TypeError, match="set: `m` must be a number, not bool"):
        ezy.run("sleigh", set={"m": True}, t_end=0.1)
    s = ezy.scene("sleigh")
    with pytest.raises(TypeError, match=r'scene\["m"\] must be a number, not bool'):
        s["m"] = True
    with pytest.raises(TypeError, match="`m` must be a number, not bool"):
        s.set("m", False)
    assert s.sets == []
    with pytest.raises(TypeError, match="a value of `m` must be a number, not bool"):
        ezy.sweep("sleigh", {"m": [1.0, True]})
    with pytest.raises(TypeError, match="`states` must be a whole number >= 0, not bool"):
        ezy.check("chaplygin_sleigh", states=True)
    with pytest.raises(TypeError, match="`max_steps` must be a whole number >= 0, not bool"):
        ezy.run("sleigh", max_steps=True)
    # the counts of sweep, geometry and optimize (pyo3 took True as 1)
    with pytest.raises(TypeError, match=r"sweep\(\): `jobs` must be a whole number >= 0, not bool"):
        ezy.sweep("sleigh", {"m": [1.0, 2.0]}, jobs=True)
    with pytest.raises(TypeError, match=r"geometry\(\): `grid` must be a whole number >= 0, not bool"):
        ezy.geometry("ezyroller", grid=True)
    over = {"motor.omega": (0.5, 8.0)}
    with pytest.raises(TypeError, match=r"optimize\(\): `max_evaluations` must be a whole number >= 0, not bool"):
        ezy.optimize("drive-rolling-resistance", over=over, maximize="gait.mean_speed", max_evaluations=True)
    with pytest.raises(TypeError, match=r"optimize\(\): `grid` must be a whole number >= 0, not bool"):
        ezy.optimize("drive-rolling-resistance", over=over, maximize="gait.mean_speed", grid=False)
    with pytest.raises(TypeError, match=r"`jobs` must be a whole number >= 0, not float"):
        ezy.sweep("sleigh", {"m": [1.0, 2.0]}, jobs=1.5)


def test_ctrl_c_stops_a_long_check_within_a_second(sigint_raises):
    # some 10 s unless stopped (1.8e7 states x coordinates); it answered
    # only at its end
    took = interrupted_after(0.5, ezy.check, "snake", set={"N": 60}, states=100000)
    assert took < 1.0, took
    # absurd counts are refused by name before any state
    with pytest.raises(ezy.EzyError, match="`states=100000000`.*1e8"):
        ezy.check("snake", set={"N": 60}, states=100_000_000)


def many_bodies(n):
    bodies = "".join(f"    body b{i}(x{i}, y{i}, p{i}) {{ mass: m, inertia: I }}\n" for i in range(n))
    return "pub struct Many {\n    param m = 1.0;\n    param I = 0.1;\n" + bodies + "}\n"


def test_a_model_derives_with_the_gil_released_and_answers_ctrl_c(sigint_raises):
    # another thread runs while a model derives (it held the GIL: 1 %)
    count, stop = [0], []

    def spin():
        while not stop:
            count[0] += 1

    spinner = threading.Thread(target=spin)
    spinner.start()
    time.sleep(0.3)
    before, t0 = count[0], time.monotonic()
    time.sleep(0.3)
    alone = (count[0] - before) / (time.monotonic() - t0)
    before, t0 = count[0], time.monotonic()
    ezy.Model(many_bodies(50))
    during = (count[0] - before) / (time.monotonic() - t0)
    stop.append(True)
    spinner.join()
    assert during > 0.1 * alone, (during, alone)
    # Ctrl-C answers within a second (it came after the derivation's 6 s)
    took = interrupted_after(0.5, ezy.Model, many_bodies(100))
    assert took < 1.0, took
    # a text of more bodies than the derivation takes is refused by count
    start = time.monotonic()
    with pytest.raises(ezy.EzyError, match="101 bodies.*100.*cube"):
        ezy.Model(many_bodies(101))
    assert time.monotonic() - start < 1.0
