"""What a call from Python says (issue 85, item 3): its refusals name the
call's keywords, never the command line's flags, and its reports name no
file that is gone.

Run by `cargo test` (python/tests/pytest.rs), as test_ezy.py.
"""

import re
from pathlib import Path

import pytest

import ezy

OVER = {"motor.omega": (1.0, 6.0)}

# (the call, a keyword its refusal must name): each refusal comes from the
# command line's own check, whose text names a flag there
REFUSALS = [
    (lambda: ezy.sweep("drive", {"M0": [1, 2]}, max_steps=10), "`max_steps=600000`"),
    (lambda: ezy.sweep("drive", {"M0": [1, 2]}, set={"M0": 1}), "`set=`"),
    (lambda: ezy.sweep("drive", {"M0": "1:2"}), "`grid=`"),
    (lambda: ezy.sweep("drive", {"M0": [1]}, jobs=0), "`jobs=0`"),
    (lambda: ezy.sweep("drive", {"bogus": [1]}), "the grid's axis or `set=`"),
    (lambda: ezy.sweep("drive", {"M0": [1]}, metrics=["mean(x1, 0, 0.001)"], every=1.0), "`every=`"),
    (lambda: ezy.analyze("drive", period=-1), "`period=`"),
    (lambda: ezy.analyze("drive", energy=-1), "`energy=`"),
    (lambda: ezy.analyze("drive", vary="M0=1:2"), "`vary=`"),
    (lambda: ezy.analyze("drive", vary="M0=1:2:3"), "`vary=`"),
    (lambda: ezy.analyze("drive", switch=True), "`switch=`"),
    (lambda: ezy.analyze("four-bar", wrt="c"), "`wrt=`"),
    (lambda: ezy.linearize("drive", at=-1.0), "`at=-1`"),
    (lambda: ezy.sensitivity("drive", wrt="M0,M0"), "`wrt=`"),
    (lambda: ezy.optimize("drive", maximize="final(x1)", over=OVER, subject_to="bogus"), "`subject_to=`"),
    (lambda: ezy.optimize("drive", maximize="nonsense(x1)", over=OVER), "`maximize=`"),
    (lambda: ezy.optimize("drive", minimize="nonsense(x1)", over=OVER), "`minimize=`"),
    (lambda: ezy.optimize("drive", maximize="final(x1)", over=OVER, max_evaluations=1), "`max_evaluations=`"),
    (lambda: ezy.optimize("drive", maximize="final(x1)", over=OVER, grid=100000), "`grid=`"),
    (lambda: ezy.geometry("kinematic-snake", grid=1), "`grid=1`"),
    (lambda: ezy.geometry("kinematic-snake", rtol=1.0), "`rtol=1`"),
    (lambda: ezy.geometry("kinematic-snake", range=(1.0, 0.0)), "`range=`"),
    (lambda: ezy.geometry("kinematic-snake", gait="alpha1=t"), "`gait=`"),
    (lambda: ezy.geometry("kinematic_snake", at={"alpha1": 0.3}), "`at=`"),
    (lambda: ezy.check("ezyroller", states=0), "`states`"),
    # a run in memory: the library's `method = dop853` as the keyword
    (lambda: ezy.run("drive", integrator="rk4", dt=0.5), '`integrator="dop853"`'),
    (lambda: ezy.linearize("drive", at=1e9), "`max_steps=1e13`"),
]


@pytest.mark.parametrize("call,keyword", REFUSALS, ids=[k for _, k in REFUSALS])
def test_a_refusal_names_the_keyword_not_the_flag(call, keyword):
    with pytest.raises(ezy.EzyError) as e:
        call()
    message = str(e.value)
    assert "--" not in message and keyword in message, message
    # nor the argument parser's advice to read --help, nor its `error: `
    assert not message.startswith("error") and "help" not in message, message


def test_a_sweep_on_more_jobs_than_cores_says_no_flag(capfd):
    ezy.sweep("drive", {"M0": [1.0, 2.0]}, jobs=4096, t_end=0.1)
    out, err = capfd.readouterr()
    assert "--" not in out + err, out + err


def paths(report):
    """The absolute paths a report names."""
    return re.findall(r"(?:^|\s)(/[^\s,;`'\")]+)", report)


def fit_data():
    run = ezy.run("drive-rolling-resistance", set={"rolling_A.damping": 1.3}, t_end=2.0, every=0.1)
    return run.to_pandas()[["t", "x1", "y1"]]


# (the call, its report, the tables the report says are in the object)
CALLS = {
    "analyze": (
        lambda **kw: ezy.analyze("drive-rolling-resistance", vary="motor.amplitude=0.5:1:3", **kw),
        lambda r: r.report,
        ".periodic, .branch of the returned object",
    ),
    "geometry": (
        lambda **kw: ezy.geometry("kinematic-snake", grid=5, **kw),
        lambda r: r.report,
        '.connection, .curvature, .gait, .tables["gait_path"] of the returned object',
    ),
    "linearize": (
        lambda **kw: ezy.linearize("drive", at=1.0, **kw),
        lambda r: r.report,
        ".A, .eigenvalues, .state of the returned object",
    ),
    "sensitivity": (
        lambda **kw: ezy.sensitivity("drive", wrt="M0", t_end=0.5, **kw),
        lambda r: r.attrs["report"],
        "table: the returned DataFrame",
    ),
    "optimize": (
        lambda **kw: ezy.optimize("drive", maximize="final(x1)", over=OVER, t_end=2.0, grid=3, **kw),
        lambda r: r.attrs["report"],
        'the returned DataFrame, its .attrs["history"], its .attrs["grid"]',
    ),
    "fit": (
        lambda **kw: ezy.fit(
            "drive-rolling-resistance", data=fit_data(), columns=["x1", "y1"], over={"rolling_A.damping": (0.0, 5.0)}, **kw
        ),
        lambda r: r.attrs["report"],
        "table: the returned DataFrame",
    ),
}


@pytest.mark.parametrize("function", list(CALLS))
def test_a_report_names_no_file_that_is_gone(function, tmp_path):
    call, report_of, tables = CALLS[function]
    # without out=: the tables are in the returned object, no file named
    report = report_of(call())
    assert paths(report) == [] and "wrote" not in report, report
    assert tables in report and "give out=DIR" in report, report
    assert "--" not in report, report
    # with out=: each file it names is there
    out = tmp_path / "out"
    report = report_of(call(out=out))
    wrote = [Path(line[len("wrote ") :]) for line in report.splitlines() if line.startswith("wrote ")]
    assert wrote and all(p.is_file() and p.parent == out for p in wrote), report
    assert set(paths(report)) == {str(p) for p in wrote}, report
    assert "out=DIR" not in report, report


def test_figures_drawn_without_out_are_said_to_be_gone():
    a = ezy.analyze("drive-rolling-resistance", figures=True)
    assert paths(a.report) == [] and "deleted with it: multipliers.png" in a.report, a.report


def test_an_optimum_not_kept_names_no_deleted_file(tmp_path):
    # a search out of budget: its best point is in out=, or said lost
    kw = dict(maximize="final(x1)", over=OVER, t_end=2.0, max_evaluations=2, grid=0)
    with pytest.raises(ezy.EzyError, match="not converged") as e:
        ezy.optimize("drive", **kw)
    assert paths(str(e.value)) == [] and "out=DIR keeps it" in str(e.value), str(e.value)
    with pytest.raises(ezy.EzyError, match="not converged") as e:
        ezy.optimize("drive", out=tmp_path / "o", **kw)
    assert paths(str(e.value))[0] == str(tmp_path / "o" / "optimum.csv") and (tmp_path / "o" / "optimum.csv").is_file()
