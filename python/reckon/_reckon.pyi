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
    events: Sequence[tuple[Callable[..., float], bool, float]],
    max_steps: int | None,
) -> dict[str, Any]: ...
