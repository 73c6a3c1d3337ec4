"""Type stubs of the `ezy` extension module (planar vehicles with hinges and
skates). Units are SI: lengths [m], angles [rad], times [s], energies [J].
Refused input raises EzyError with the command line's message."""

from os import PathLike
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike]
_Grid = Mapping[str, Union[Sequence[float], str]]

class EzyError(Exception):
    """A scene, model, setting or run that ezy refused; the message names
    the culprit (file, line, key, flag or value)."""

class Model:
    """A vehicle read from the text of a model (what goes between the braces
    of `model! { ... }`), derived when it is made and evaluated by machine
    code compiled for it."""

    key: str
    def __init__(self, text: str, *, key: Optional[str] = None) -> None: ...
    @staticmethod
    def load(path: _Path, *, key: Optional[str] = None) -> "Model": ...
    @property
    def name(self) -> str: ...
    @property
    def params(self) -> Dict[str, float]: ...
    @property
    def coords(self) -> List[str]: ...
    def equations(self) -> "Equations": ...

class Effect:
    """One effect's or drive's numbers of a Scene, as attributes."""

    def numbers(self) -> Dict[str, float]: ...
    def __getattr__(self, key: str) -> float: ...
    def __setattr__(self, key: str, value: float) -> None: ...

class Scene:
    """A scene to change and run: `scene["M0"] = 1.0`,
    `scene.effects["motor"].amplitude = 3.0`, `scene.run()`."""

    @property
    def name(self) -> str: ...
    @property
    def model(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def file(self) -> str: ...
    @property
    def t_end(self) -> float: ...
    @property
    def sets(self) -> List[Tuple[str, float]]: ...
    @property
    def params(self) -> Dict[str, float]: ...
    @property
    def effects(self) -> Dict[str, Effect]: ...
    def __getitem__(self, name: str) -> float: ...
    def __setitem__(self, name: str, value: float) -> None: ...
    def __delitem__(self, name: str) -> None:
        """Takes back what `scene[name] = value` set: the file's number again."""
        ...
    def set(self, name: str, value: float) -> "Scene": ...
    def run(self, **settings: Any) -> "Result": ...

class Result:
    """A finished run in memory: `len()` counts the rows, iterating gives
    them, `np.asarray(result)` is the table (rows x columns)."""

    scene: str
    summary: str
    warnings: List[str]
    notes: List[str]
    @property
    def data(self) -> npt.NDArray[np.float64]: ...
    @property
    def columns(self) -> List[str]: ...
    @property
    def t(self) -> npt.NDArray[np.float64]: ...
    @property
    def stats(self) -> Dict[str, Any]: ...
    @property
    def figures(self) -> List[str]: ...
    @property
    def units(self) -> Dict[str, str]: ...
    def describe(self) -> str: ...
    def keys(self) -> List[str]: ...
    def to_pandas(self) -> Any: ...
    def plot(self, name: str, ax: Any = None) -> Any: ...
    def __getitem__(self, name: str) -> npt.NDArray[np.float64]: ...
    def __contains__(self, name: str) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.float64]]: ...
    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> npt.NDArray[np.float64]: ...

class Equations:
    """A model's derived equations: `str()` the text, Jupyter the LaTeX."""

    text: str
    latex: str
    def _repr_latex_(self) -> str: ...

class Check:
    """Derived terms against automatic differentiation: truthy if passed."""

    passed: bool
    table: str
    message: str
    def __bool__(self) -> bool: ...

class Analysis:
    """Steady motions, a gait, a limit cycle or a growth without bound: the report and its tables as DataFrames."""

    report: str
    tables: Dict[str, Any]
    @property
    def periodic(self) -> Any: ...
    @property
    def equilibria(self) -> Any: ...
    @property
    def branch(self) -> Any: ...
    @property
    def growth(self) -> Any: ...

class Geometry:
    """The geometry of locomotion: the report and its tables as DataFrames."""

    report: str
    tables: Dict[str, Any]
    @property
    def connection(self) -> Any: ...
    @property
    def curvature(self) -> Any: ...
    @property
    def momentum(self) -> Any: ...
    @property
    def gait(self) -> Any: ...

class Linearization:
    """A and B at a time of a run (DataFrames), the eigenvalues [1/s]."""

    report: str
    A: Any
    B: Any
    eigenvalues: npt.NDArray[np.complex128]
    state: Dict[str, float]

class Toolkit: ...

_Scene = Union[str, _Path, Scene]

def models() -> Dict[str, str]: ...
def scenes() -> Dict[str, str]: ...
def effect_kinds() -> Dict[str, Dict[str, Any]]: ...
def scene(
    name: Optional[str] = None,
    *,
    toml: Optional[str] = None,
    model: Union[None, str, Model] = None,
    **keys: Any,
) -> Scene: ...
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
) -> Result: ...
def sweep(
    scene: _Scene,
    grid: _Grid,
    *,
    model: Optional[Model] = None,
    metrics: Optional[Sequence[str]] = None,
    jobs: Optional[int] = None,
    out: Optional[_Path] = None,
    **settings: Any,
) -> Any: ...
def analyze(
    scene: _Scene,
    *,
    model: Optional[Model] = None,
    period: Optional[float] = None,
    energy: Optional[float] = None,
    vary: Optional[str] = None,
    wrt: Union[str, Sequence[str], None] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Analysis: ...
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
) -> Geometry: ...
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
) -> Any: ...
def optimize(
    scene: _Scene,
    *,
    over: Mapping[str, Tuple[float, float]],
    maximize: Optional[str] = None,
    minimize: Optional[str] = None,
    subject_to: Optional[Union[str, Sequence[str]]] = None,
    max_evaluations: Optional[int] = None,
    grid: Optional[int] = None,
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any: ...
def sensitivity(
    scene: _Scene,
    *,
    wrt: Union[str, Sequence[str]],
    model: Optional[Model] = None,
    out: Optional[_Path] = None,
    figures: bool = False,
    **settings: Any,
) -> Any: ...
def linearize(
    scene: _Scene,
    *,
    model: Optional[Model] = None,
    at: Optional[float] = None,
    input: Optional[str] = None,
    out: Optional[_Path] = None,
    **settings: Any,
) -> Linearization: ...
def equations(model: Union[str, Model], *, set: Optional[Mapping[str, float]] = None) -> Equations: ...
def check(
    model: Union[str, Model],
    *,
    set: Optional[Mapping[str, float]] = None,
    states: Optional[int] = None,
    seed: Optional[int] = None,
) -> Check: ...
