"""Type stubs of the `ezy` extension module (planar vehicles with hinges and
skates). Units are SI: lengths [m], angles [rad], times [s], energies [J].
Refused input raises EzyError with the command line's message, its flags
said as the keywords of the call."""

from os import PathLike
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike]
_Grid = Mapping[str, Union[Sequence[float], str]]

class EzyError(Exception):
    """A scene, model, setting or run that ezy refused; the message names
    the culprit (file, line, key, keyword or value). The command line's
    flags are said as the keywords of the call (`vary=` for `--continue`,
    `rtol=1e-3` for `--rtol 1e-3`)."""

class Model:
    """A vehicle read from the text of a model (what goes between the braces
    of `model! { ... }`), derived when it is made and evaluated by machine
    code compiled for it."""

    key: str
    """The name commands know it by (default: the struct's name)."""
    def __init__(self, text: str, *, key: Optional[str] = None) -> None: ...
    @staticmethod
    def load(path: _Path, *, key: Optional[str] = None) -> "Model":
        """The model in a `.ezy` file, derived as `Model(text)` is."""
        ...
    @property
    def name(self) -> str:
        """The struct's name (`RollerRacer`)."""
        ...
    @property
    def params(self) -> Dict[str, float]:
        """The parameters and family counts: `{name: value}` (SI units)."""
        ...
    @property
    def coords(self) -> List[str]:
        """The generalized coordinates' names, in order."""
        ...
    def equations(self) -> "Equations":
        """The derived equations (LaTeX in Jupyter)."""
        ...

class Effect:
    """One effect's or drive's numbers of a Scene, as attributes:
    `scene.effects["motor"].omega = 6.283` sets `motor.torque.cos.omega`
    (a number is named by its last key)."""

    def numbers(self) -> Dict[str, float]:
        """Every number of the effect: `{"torque.cos.amplitude": 1.0, ...}`."""
        ...
    def __getattr__(self, key: str) -> float: ...
    def __setattr__(self, key: str, value: float) -> None: ...

class Scene:
    """A scene to change and run: `scene["M0"] = 1.0`,
    `scene.effects["motor"].amplitude = 3.0`, `del scene["M0"]`,
    `scene.run()`. Values are numbers in SI units."""

    @property
    def name(self) -> str:
        """The scene's name."""
        ...
    @property
    def model(self) -> str:
        """The key of the model it runs on."""
        ...
    @property
    def description(self) -> str: ...
    @property
    def file(self) -> str:
        """The scene file it was read from (`<keywords>` or `<toml>` for one made in Python)."""
        ...
    @property
    def t_end(self) -> float:
        """The end time [s]."""
        ...
    @property
    def sets(self) -> List[Tuple[str, float]]:
        """The changes made on this object, in order: `[(name, value)]`."""
        ...
    @property
    def params(self) -> Dict[str, float]:
        """The scene's and the model's parameters with the sets applied."""
        ...
    @property
    def effects(self) -> Dict[str, Effect]:
        """Each effect and drive by name."""
        ...
    def __getitem__(self, name: str) -> float: ...
    def __setitem__(self, name: str, value: float) -> None: ...
    def __delitem__(self, name: str) -> None:
        """Takes back what `scene[name] = value` set: the file's number again."""
        ...
    def set(self, name: str, value: float) -> "Scene":
        """`scene[name] = value`, returning the scene (to chain)."""
        ...
    def run(self, **settings: Any) -> "Result":
        """`ezy.run(scene, **settings)`."""
        ...

class Result:
    """A finished run in memory: `len()` counts the rows, iterating gives
    them, `np.asarray(result)` is the table (rows x columns)."""

    scene: str
    """The scene's name."""
    summary: str
    """What `ezy run` prints: method, steps, evaluations, times, residuals, energy balance, final state."""
    warnings: List[str]
    """The run's warnings (corrected initial values, an ill-conditioned KKT system)."""
    notes: List[str]
    """The run's notes (the assembly branch taken, hand-overs)."""
    @property
    def data(self) -> npt.NDArray[np.float64]:
        """Every output row: a float64 array, rows x columns."""
        ...
    @property
    def columns(self) -> List[str]:
        """The column names (trajectory.csv's), in order."""
        ...
    @property
    def t(self) -> npt.NDArray[np.float64]:
        """The output times [s]."""
        ...
    @property
    def stats(self) -> Dict[str, Any]:
        """method, steps, rejected, rhs_evals, integration_s, setup_s, wall_s [s], max_energy_gap [J], handovers."""
        ...
    @property
    def figures(self) -> List[str]:
        """The names of the scene's figures (`plot` draws them)."""
        ...
    @property
    def units(self) -> Dict[str, str]:
        """Each column's unit: `{"x1": "m", "x1d": "m/s", ...}` ("" for a pure number)."""
        ...
    def describe(self) -> str:
        """Each column, its unit and what it is, one line each."""
        ...
    def keys(self) -> List[str]: ...
    def to_pandas(self) -> Any:
        """The rows as a pandas DataFrame (units in `.attrs["units"]`)."""
        ...
    def plot(self, name: str, ax: Any = None) -> Any:
        """Draws the scene's figure `name` with matplotlib; returns the Figure."""
        ...
    def __getitem__(self, name: str) -> npt.NDArray[np.float64]: ...
    def __contains__(self, name: str) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.float64]]: ...
    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> npt.NDArray[np.float64]: ...

class Equations:
    """A model's derived equations: `str()` the text, Jupyter the LaTeX."""

    text: str
    """The plain text `ezy equations` prints."""
    latex: str
    """The whole LaTeX document."""
    def _repr_latex_(self) -> str: ...

class Check:
    """Derived terms against automatic differentiation: truthy if passed."""

    passed: bool
    """Whether every derived term matched its reference within its tolerance."""
    table: str
    """The table `ezy check` prints."""
    message: str
    """Why the check failed (empty when it passed)."""
    def __bool__(self) -> bool: ...

class Analysis:
    """Steady motions, a gait, a limit cycle or a growth without bound:
    the report (`str()`) and its tables as DataFrames. A table the
    analysis did not write is None (and not a key of `tables`)."""

    report: str
    """What `ezy analyze` prints; its last line says where the tables are."""
    tables: Dict[str, Any]
    """Keys: "periodic", "equilibria", "branch", "growth" (those written)."""
    @property
    def periodic(self) -> Any:
        """The gait or limit cycle, one row per orbit: `period` [s], `t0` [s]
        (its phase), `stability`, `family`, `mean_speed` and
        `mean_forward_speed` [m/s], `dx`, `dy` [m] and `dheading` [rad] per
        period in the reference body's frame, hinge angles `theta_<H>`
        [rad], the fixed point (the state), Floquet multipliers
        `mu<k>_re`, `mu<k>_im`, a gait's `mean_power` [W] and `efficiency`
        [m/J], and with `wrt=` the derivatives `d<quantity>/d<param>`."""
        ...
    @property
    def equilibria(self) -> Any:
        """The steady motions: `motion`, `stability`, `family`, the reference
        body's velocity in its own frame `u`, `v` [m/s] and yaw rate `omega`
        [rad/s], `speed` [m/s], `curvature` [1/m], the state, eigenvalues
        `lambda<k>_re`, `lambda<k>_im` [1/s]."""
        ...
    @property
    def branch(self) -> Any:
        """With `vary=`: one row per value of the parameter (its column
        first), `stability`, `speed`, `period`, `t0`, the state, multipliers
        or eigenvalues, `mean_power`, `efficiency`; a located bifurcation's
        row has its kind in `bifurcation` and `critical_re`, `critical_im`."""
        ...
    @property
    def branches(self) -> List[Any]:
        """With `switch=`: every branch's DataFrame, the one followed first
        (`.branch`), then each born at one of its bifurcations (numbered
        as in `.diagram`); without, `[.branch]` or `[]`."""
        ...
    @property
    def diagram(self) -> Any:
        """With `switch=`: one row per branch: `branch` (0 the one followed),
        `file`, `parent`, `born_at` (the bifurcation's parameter value),
        `bifurcation` (transcritical, pitchfork, period doubling, Hopf),
        `criticality` (supercritical, subcritical), `symmetry_breaking`,
        `side`, `points`, `from`, `to`, `ended`; or None."""
        ...
    @property
    def growth(self) -> Any:
        """A driven motion that gains energy without bound: one row per
        window, `t_start`, `t_end` [s], `T_start`, `T_end` [J], the power laws
        `energy_exponent` and `speed_exponent` with standard errors."""
        ...
    @property
    def units(self) -> Dict[str, Dict[str, str]]:
        """Each table's columns' units: `{"periodic": {"drift_speed": "m/s",
        ...}}` ("" for a pure number), from the guide's Quantities page."""
        ...
    def describe(self) -> str:
        """Each table's columns with unit, meaning, and the frame and time
        they are taken at (`dx`, `dy`: the reference body's frame at `t0`;
        `drift_speed`: independent of `t0`)."""
        ...

class Geometry:
    """The geometry of locomotion: the report (`str()`) and its tables as
    DataFrames (None where not written)."""

    report: str
    """What `ezy geometry` prints; its last line says where the tables are."""
    tables: Dict[str, Any]
    """Keys: "connection", "curvature", "momentum", "gait", "gait_path" (those written)."""
    @property
    def connection(self) -> Any:
        """At each shape: the shape [rad], the local connection `A_<u,v,w>_<hinge>`
        (body velocity per shape velocity: [m/rad] for u, v, [1] for w),
        `Gamma_<u,v,w>_<p>` for a mixed system, and `rank_margin`."""
        ...
    @property
    def curvature(self) -> Any:
        """At each shape (two or more shape coordinates): the height functions
        `DA_<x,y,theta>_<i>_<j>`, the net motion per unit area of a small
        loop in the shape plane."""
        ...
    @property
    def momentum(self) -> Any:
        """At each shape (a mixed system): `<p>:<z_a>*<z_b>`, the coefficient
        of `z_a z_b` in the momentum equation `p'`, `z = [r', p]`."""
        ...
    @property
    def gait(self) -> Any:
        """One row per `method` ("first-order", "second-order",
        "reconstructed", "simulated"): the net motion per cycle `dx`, `dy`
        [m], `dtheta` [rad] in the initial body frame, and a mixed system's
        momentum after the cycle `<p>_end`."""
        ...
    @property
    def gait_path(self) -> Any:
        """Along one period: `t` [s], the shape [rad], and the reference
        body's pose reconstructed (`x_reconstructed`, `y_reconstructed` [m],
        `theta_reconstructed` [rad]) and simulated (`x_simulated`, ...).
        Also `tables["gait_path"]`."""
        ...
    @property
    def units(self) -> Dict[str, Dict[str, str]]:
        """Each table's columns' units: `{"gait": {"dx": "m", ...}}` ("" for a
        pure number), from the guide's Quantities page."""
        ...
    def describe(self) -> str:
        """Each table's columns with unit, meaning, and the frame and time
        they are taken at."""
        ...

class Linearization:
    """A and B at a time of a run (DataFrames), the eigenvalues [1/s]."""

    report: str
    """What `ezy linearize` prints; its last line says where the tables are."""
    A: Any
    """The state matrix (2 nq x 2 nq), rows and columns named by the state (q, then qd)."""
    B: Any
    """The input matrix (2 nq x 1) for `input=`, or None."""
    eigenvalues: npt.NDArray[np.complex128]
    """The eigenvalues on the constraint manifold [1/s]."""
    state: Dict[str, float]
    """The state linearized about: `{name: value}` (SI units)."""

class Toolkit:
    """The application behind the module: its methods are the module's
    functions (`ezy.run` is `Toolkit.run` of the built-in vehicles)."""

_Scene = Union[str, _Path, Scene]

def models() -> Dict[str, str]:
    """The models this module knows: `{key: description}`."""
    ...
def scenes() -> Dict[str, str]:
    """The scenes this module knows: `{name: description}`."""
    ...
def effect_kinds() -> Dict[str, Dict[str, Any]]:
    """The effect kinds a scene may name: `{kind: {"builtin", "keys", "law", "value_column"}}`."""
    ...
def scene(
    name: Optional[str] = None,
    *,
    toml: Optional[str] = None,
    model: Union[None, str, Model] = None,
    **keys: Any,
) -> Scene:
    """A scene to change and run: a known name, `toml=` text, or a scene file's keys as keywords with `model=`."""
    ...
def run(
    scene: _Scene,
    *,
    model: Optional[Model] = None,
    set: Optional[Mapping[str, float]] = None,
    integrator: Optional[str] = None,
    formulation: Optional[str] = None,
    projection: Optional[str] = None,
    rtol: Optional[float] = None,
    atol: Optional[float] = None,
    dt: Optional[float] = None,
    t_end: Optional[float] = None,
    every: Optional[float] = None,
    max_steps: Optional[int] = None,
    max_output_mb: Optional[float] = None,
) -> Result:
    """Runs `scene` in memory: every output row as NumPy arrays."""
    ...
def sweep(
    scene: _Scene,
    grid: _Grid,
    *,
    model: Optional[Model] = None,
    metrics: Optional[Sequence[str]] = None,
    jobs: Optional[int] = None,
    out: Optional[_Path] = None,
    **settings: Any,
) -> Any:
    """Runs `scene` over `grid` (`{"M0": [1, 2]}` or `{"M0": "1:3:5"}`): a
    DataFrame, one row per run: `run`, the swept values, `status`,
    `wall_s` [s], `steps`, `rejected`, `rhs_evals`, the final state (SI
    units), the effects' work `W_<name>` [J], the kinetic energy `T` [J],
    the residuals `max_res_phi`, `max_res_vel`, `max_energy_gap` [J], and
    each of `metrics` by its text. A scene's set of a swept name is
    overridden by the grid."""
    ...
def analyze(
    scene: _Scene,
    *,
    model: Optional[Model] = None,
    period: Optional[float] = None,
    energy: Optional[float] = None,
    vary: Optional[str] = None,
    switch: Union[bool, int, None] = None,
    wrt: Union[str, Sequence[str], None] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Analysis:
    """Steady motions, a gait or a limit cycle and their stability, as
    `ezy analyze`: `period=` [s], `energy=` [J], `vary="NAME=START:STOP:COUNT"`
    (a branch: `.branch`), with `switch=True` (or `k`: the k-th) the
    branches born at its bifurcations too (`.branches`, `.diagram`),
    `wrt=` (the gait's derivatives in `.periodic`)."""
    ...
def geometry(
    target: Union[_Scene, Model],
    *,
    model: Optional[Model] = None,
    at: Optional[Dict[str, float]] = None,
    gait: Optional[str] = None,
    grid: Optional[int] = None,
    range: Optional[Tuple[float, float]] = None,
    body: Optional[str] = None,
    shape: Union[str, Sequence[str], None] = None,
    momentum: Optional[Dict[str, float]] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Geometry:
    """The geometry of locomotion of a model with the plane's symmetry: the local
    connection, the curvature, the momentum equation and a gait's net motion
    (`gait="alpha1=0.9+0.6*cos(t),..."`, t over [0, 2 pi]; default: the
    scene's drives). `at={shape: value}` [rad] one shape, `grid` points per
    shape coordinate over `range` [rad]."""
    ...
def fit(
    scene: _Scene,
    *,
    data: Union[_Path, Any],
    columns: Union[str, Sequence[str]],
    over: Mapping[str, Tuple[float, float]],
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any:
    """Fits numbers of `scene` to a measured run (`data`: a CSV path or a
    DataFrame with `t` [s] and `columns`), each in `over={name: (lower,
    upper)}` and started from the scene's value: a DataFrame indexed by
    `parameter` with `estimate` and `std_error` (the parameter's units);
    `.attrs["report"]` has the correlations and the residual (rms) per
    column in the column's unit."""
    ...
def optimize(
    scene: _Scene,
    *,
    over: Mapping[str, Tuple[float, float]],
    maximize: Optional[str] = None,
    minimize: Optional[str] = None,
    subject_to: Optional[Union[str, Sequence[str]]] = None,
    max_evaluations: Optional[int] = None,
    grid: Optional[int] = None,
    gait: Optional[str] = None,
    period: Optional[float] = None,
    harmonics: Optional[int] = None,
    range: Optional[Mapping[str, Tuple[float, float]]] = None,
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any:
    """Optimizes numbers of `scene` within `over={name: (lower, upper)}`:
    `maximize` or `minimize` a gait's quantity (`"gait.mean_speed"`), a
    run's metric (`"final(x1)"`) or a function of your own; `subject_to`
    constraints (`"gait.mean_power <= 1"`). A one-row DataFrame: the
    parameters, the objective and the constrained quantities at the
    optimum; `.attrs["history"]` every evaluation (with the gradient
    `d<objective>/d<param>` and `failure`), `.attrs["grid"]` the grid's
    points (with `grid=` > 0), `.attrs["report"]` the report. Each of the
    three has `.attrs["units"]` (`{column: unit}`) and
    `.attrs["description"]` (each column's unit, meaning, frame and time).
    With `gait="D=-pi+0.3*cos(t)"` (one period, t in [0, 2 pi], per drive
    of the scene's model) the numbers are the drives' Fourier
    coefficients instead (`over={"D.a1": (0.05, 0.4)}`), the gait
    stretched to `period` seconds (default: the scene's drives' period),
    of order `harmonics`, each drive's angle held within
    `range={"D": (lower, upper)}` [rad] over the cycle."""
    ...
def plan(
    scene: _Scene,
    *,
    input: Union[str, Sequence[str]],
    bound: Optional[Mapping[str, Tuple[float, float]]] = None,
    to: Optional[Mapping[str, float]] = None,
    at_rest: bool = False,
    segments: Optional[int] = None,
    evaluations: Optional[int] = None,
    intervals: Optional[int] = None,
    guess: Optional[Union[_Path, Any]] = None,
    objective: Optional[Callable[..., Any]] = None,
    effort_weight: Optional[float] = None,
    path: Optional[Union[str, Tuple[Callable[..., Any], Optional[float], Optional[float]], Sequence[Any]]] = None,
    minimize: Optional[str] = None,
    time_weight: Optional[float] = None,
    free_time: Optional[Tuple[float, float]] = None,
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any:
    """The least-effort inputs that take `scene` from its initial state to a
    target at its t_end: `input` names the effects' time functions planned
    (`"motor.torque"`), each a piecewise-linear table on `segments`
    segments (`intervals` shooting intervals of them, default 1: single
    shooting), from the warm start `guess` (a CSV file's path or a
    DataFrame: `t` [s] and one column per input, an earlier plan's),
    within `bound={input: (lower, upper)}`; the target
    `to={"x1": 1.0}` (a velocity is its coordinate's name with `d`) and
    `at_rest=True`. A DataFrame of the nodes (`t` [s], the inputs, the
    state); `.attrs["summary"]` (status, effort [unit^2 s], the objective
    minimized, `objective_value`, `objective_gradient`, violation, the
    verification run's errors), `.attrs["report"]`. A target not met
    (infeasible, with the least violation) raises EzyError.

    The objective is the effort times `effort_weight` (default 1) plus,
    with `objective=f`, `f(t, q, qd, u)` of the samples at the N + 1
    nodes: numpy arrays `t` (N + 1,) [s], `q` and `qd` (N + 1, nq), `u`
    (N + 1, inputs). `f` returns a float (ezy then differences it with
    respect to the samples: `summary["objective_gradient"]` is
    "differenced") or `(value, gradients)`, the gradients with respect to
    q, qd and u as a dict `{"q": .., "qd": .., "u": ..}` (a key left out:
    zeros) or a tuple `(gq, gqd, gu)` shaped as the samples ("exact").
    With `objective` the target may be left out (a free end). An
    exception `f` raises reaches the caller as raised; a NaN or infinite
    value or gradient raises EzyError naming it.

    `path` bounds the run at every node: a state column as text
    (`"x1d<=0.6"`, `"-1<=y1<=1"`), or `(g, lo, hi)` with `g(t, q, qd, u)`
    of one node's sample (arrays of one row; `lo`/`hi` None for none),
    or a list of them; `summary["path_excess"]` is the verification run's
    largest excess between the nodes. `free_time=(lo, hi)` [s] frees the
    duration (started at the scene's t_end; `summary["t_end"]` the one
    planned); `minimize="time"` then plans the least time, and
    `time_weight=c` adds `c T` to the effort (or to `objective`)."""
    ...
def gait_optimize(
    target: Union[_Scene, Model],
    *,
    gait: str,
    maximize: Optional[str] = None,
    minimize: Optional[str] = None,
    per_length: bool = False,
    order: Optional[str] = None,
    harmonics: Optional[int] = None,
    centre_only: bool = False,
    range: Optional[Mapping[str, Tuple[float, float]]] = None,
    margin: Optional[float] = None,
    budget: Optional[float] = None,
    metric: Optional[Union[Sequence[Sequence[float]], Any]] = None,
    max_evaluations: Optional[int] = None,
    body: Optional[str] = None,
    set: Optional[Mapping[str, float]] = None,
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
) -> Any:
    """A kinematic system's best closed gait from `gait` (one period, t in
    [0, 2 pi]): the Fourier coefficients that make `maximize` or
    `minimize` (`"dx"`, `"dy"` [m], `"dtheta"` [rad], `"along(1,0)"`)
    largest or smallest (per path length with `per_length=True`) within
    `range={coordinate: (lower, upper)}` [rad], a `margin` from the
    singular set and a path-length `budget` [rad], the length in the
    shape metric `metric` (a symmetric positive definite matrix; the
    identity by default). A DataFrame of the
    coefficients (start, optimum, free); `.attrs["history"]` every
    evaluation, `.attrs["report"]`."""
    ...
def sensitivity(
    scene: _Scene,
    *,
    wrt: Union[str, Sequence[str]],
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any:
    """The run's derivatives with respect to `wrt`: a DataFrame with `t` [s]
    and `d<column>/d<param>` for each state column (`dx1/dM0`: m per unit
    of M0); `.attrs["report"]` the report, with the final derivatives;
    `.attrs["units"]` `{column: unit}` and `.attrs["description"]` each
    column's unit, meaning, frame and time."""
    ...
def linearize(
    scene: _Scene,
    *,
    model: Optional[Model] = None,
    at: Optional[float] = None,
    input: Optional[str] = None,
    out: Optional[_Path] = None,
    **settings: Any,
) -> Linearization:
    """A and B (with `input=`) at time `at` [s] of the run, the eigenvalues [1/s]."""
    ...
def equations(model: Union[str, Model], *, set: Optional[Mapping[str, float]] = None) -> Equations:
    """The derived equations of a model (LaTeX in Jupyter)."""
    ...
def check(
    model: Union[str, Model],
    *,
    set: Optional[Mapping[str, float]] = None,
    states: Optional[int] = None,
    seed: Optional[int] = None,
) -> Check:
    """The derived terms against automatic differentiation at `states` random states."""
    ...
