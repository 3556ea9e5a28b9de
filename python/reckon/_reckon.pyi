"""Type stubs of the native module (src/lib.rs)."""

from typing import Any, Callable, Sequence, overload

import numpy as np
import numpy.typing as npt

class DenseOutput:
    """The continuous solution, as scipy's OdeSolution: sol(t) is y(t)."""

    t_min: float
    t_max: float
    @property
    def ts(self) -> npt.NDArray[np.float64]: ...
    @overload
    def __call__(self, t: float) -> npt.NDArray[np.float64]: ...
    @overload
    def __call__(self, t: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...

def solve(
    fun: Callable[..., Any],
    t0: float,
    t1: float,
    y0: Sequence[float],
    method: str,
    rtol: Sequence[float],
    atol: Sequence[float],
    jac: Any,
    first_step: float | None,
    max_step: float,
    fixed_step: float | None,
    t_eval: Sequence[float] | None,
    dense: bool,
    events: Sequence[tuple[Callable[..., float], int, float]],
    max_steps: int | None,
    out: dict[str, Any],
) -> None: ...

def solve_traced(
    model: Model,
    t0: float,
    t1: float,
    y0: Sequence[float],
    method: str,
    rtol: Sequence[float],
    atol: Sequence[float],
    first_step: float | None,
    max_step: float,
    fixed_step: float | None,
    t_eval: Sequence[float] | None,
    dense: bool,
    events: Sequence[tuple[Callable[..., float], int, float]],
    max_steps: int | None,
    out: dict[str, Any],
) -> None: ...
def _rust_reference(
    problem: str, param: float, method: str, t1: float, rtol: float, atol: float, repeats: int
) -> tuple[float, list[float], int]: ...

class Symbol:
    """A traced scalar: what fun sees in place of t, each y[i] and each numeric parameter
    while reckon.Model traces it. Comparisons, bool(), float() and int() raise
    reckon.Untraceable."""

    def __add__(self, o: Symbol | float) -> Symbol: ...
    def __radd__(self, o: Symbol | float) -> Symbol: ...
    def __sub__(self, o: Symbol | float) -> Symbol: ...
    def __rsub__(self, o: Symbol | float) -> Symbol: ...
    def __mul__(self, o: Symbol | float) -> Symbol: ...
    def __rmul__(self, o: Symbol | float) -> Symbol: ...
    def __truediv__(self, o: Symbol | float) -> Symbol: ...
    def __rtruediv__(self, o: Symbol | float) -> Symbol: ...
    def __pow__(self, o: Symbol | float, modulo: None = None) -> Symbol: ...
    def __rpow__(self, o: Symbol | float, modulo: None = None) -> Symbol: ...
    def __neg__(self) -> Symbol: ...
    def __pos__(self) -> Symbol: ...
    def __abs__(self) -> Symbol: ...
    def sin(self) -> Symbol: ...
    def cos(self) -> Symbol: ...
    def tan(self) -> Symbol: ...
    def arcsin(self) -> Symbol: ...
    def arccos(self) -> Symbol: ...
    def arctan(self) -> Symbol: ...
    def sinh(self) -> Symbol: ...
    def cosh(self) -> Symbol: ...
    def tanh(self) -> Symbol: ...
    def arcsinh(self) -> Symbol: ...
    def arccosh(self) -> Symbol: ...
    def arctanh(self) -> Symbol: ...
    def exp(self) -> Symbol: ...
    def exp2(self) -> Symbol: ...
    def expm1(self) -> Symbol: ...
    def log(self) -> Symbol: ...
    def log1p(self) -> Symbol: ...
    def log2(self) -> Symbol: ...
    def log10(self) -> Symbol: ...
    def sqrt(self) -> Symbol: ...
    def cbrt(self) -> Symbol: ...
    def square(self) -> Symbol: ...
    def absolute(self) -> Symbol: ...
    def fabs(self) -> Symbol: ...
    def sign(self) -> Symbol: ...
    def arctan2(self, o: Symbol | float) -> Symbol: ...
    def hypot(self, o: Symbol | float) -> Symbol: ...
    def conjugate(self) -> Symbol: ...

class Model:
    """fun(t, y, *params) traced once into reckon's expression graph; f, the exact
    Jacobian and df/dt then run as compiled code."""

    trace_seconds: float
    compile_seconds: float
    def __init__(self, fun: Callable[..., Any], n: int, params: Sequence[Any] | None = None) -> None: ...
    @property
    def n(self) -> int: ...
    @property
    def nnz(self) -> int: ...
    @property
    def sparse(self) -> bool: ...
    @property
    def native(self) -> tuple[bool, bool]: ...
    def __call__(self, t: float, y: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def jacobian(self, t: float, y: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def pattern(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
    def sparsity(self) -> Any: ...
    def spy(self) -> str: ...
    def text(self) -> str: ...
    def jacobian_text(self) -> str: ...
    def latex(self) -> str: ...
    def mathml(self) -> str: ...
    def rhs_text(self, i: int) -> str: ...

class Statistics:
    """An ensemble's exact, mergeable statistics per saved time (src/ensemble.rs)."""

    count: int
    members: int
    seed: int
    shard_count: int
    shards: list[int]
    complete: bool
    job: str
    times: npt.NDArray[np.float64]
    names: list[str]
    moments: int
    def to_json(self) -> str: ...
    @staticmethod
    def from_json(text: str) -> Statistics: ...
    def merge(self, other: Statistics) -> Statistics: ...
    def mean(self, k: int) -> npt.NDArray[np.float64]: ...
    def covariance(self, k: int) -> npt.NDArray[np.float64]: ...
    def quantile(self, k: int, column: int | str, q: float) -> float | None: ...

def encoder_plan(spec: tuple[Any, ...]) -> tuple[str, list[float], float]: ...
def encoder_run(
    spec: tuple[Any, ...], members: int, seed: int, shard: tuple[int, int], threads: int | None
) -> Statistics: ...
def model_run(
    model: Model,
    n: int,
    mean: Sequence[float],
    factor: Sequence[float],
    t0: float,
    t1: float,
    times: Sequence[float],
    method: str,
    rtol: Sequence[float],
    atol: Sequence[float],
    first_step: float | None,
    max_step: float,
    max_steps: int | None,
    members: int,
    seed: int,
    shard: tuple[int, int],
    threads: int | None,
    job: str,
) -> Statistics: ...

# src/rest.rs: vehicles, odometry, sensitivities, calibration (wrapped by reckon.vehicles,
# reckon.odometry, reckon.sensitivities and reckon.calibration)

def vehicle_simulate(
    kind: str,
    params: Sequence[float],
    x0: Sequence[float],
    t: npt.NDArray[np.float64],
    u: npt.NDArray[np.float64],
    method: str,
    rtol: float,
    atol: float,
    max_step: float,
    step: float | None,
    max_steps: int,
) -> dict[str, Any]: ...
def vehicle_step(
    kind: str, params: Sequence[float], x: Sequence[float], u: Sequence[float], h: float | None
) -> npt.NDArray[np.float64]: ...
def odometry(
    t: npt.NDArray[np.float64],
    left: npt.NDArray[np.float64],
    right: npt.NDArray[np.float64],
    wheel_diameter: float,
    wheel_separation: float,
    pulses_per_rev: float,
    update: str,
) -> npt.NDArray[np.float64]: ...
def sensitivities(
    model: Model,
    n: int,
    params: Sequence[float],
    t0: float,
    t1: float,
    y0: Sequence[float],
    method: str,
    rtol: float,
    atol: float,
    first_step: float | None,
    max_step: float,
    fixed_step: float | None,
    t_eval: Sequence[float] | None,
    max_steps: int,
    error_control: bool,
    wrt_params: bool,
) -> dict[str, Any]: ...
def least_squares(
    model: Model,
    n: int,
    p0: Sequence[float],
    t0: float,
    y0: Sequence[float],
    t_obs: Sequence[float],
    y_obs: npt.NDArray[np.float64],
    components: Sequence[int],
    sigma: Sequence[float],
    angles: Sequence[int],
    method: str,
    rtol: float,
    atol: float,
    max_iters: int,
    tol: float,
    max_condition: float,
) -> dict[str, Any]: ...
def umbmark_fit(
    cw: npt.NDArray[np.float64], ccw: npt.NDArray[np.float64], side: float, wheelbase: float
) -> dict[str, Any]: ...
def censi_fit(
    wheels: npt.NDArray[np.float64],
    counts: Sequence[int],
    sensor: npt.NDArray[np.float64],
    trim_fraction: float,
    trim_rounds: int,
) -> dict[str, Any]: ...
def vehicle_sensitivities(
    kind: str,
    params: Sequence[float],
    x0: Sequence[float],
    t: npt.NDArray[np.float64],
    u: npt.NDArray[np.float64],
    method: str,
    rtol: float,
    atol: float,
    max_step: float,
    step: float | None,
    max_steps: int,
) -> dict[str, Any]: ...
def encoder_least_squares(
    t: npt.NDArray[np.float64],
    left: npt.NDArray[np.float64],
    right: npt.NDArray[np.float64],
    pose_t: npt.NDArray[np.float64],
    poses: npt.NDArray[np.float64],
    wheel_diameter: float,
    wheel_separation: float,
    pulses_per_rev: float,
    sigma: Sequence[float],
) -> dict[str, Any]: ...
