"""The one place that sets Numba options for sizefx kernels.

- ``cache=True``: compiled machine code is kept next to the module, so only the
  first run on a machine pays the compile time (reported apart by the benchmarks).
- ``fastmath=False``: kernels must agree with their NumPy twins to 1e-9 and give
  the same result whether a record is processed whole or in chunks; reassociating
  sums would break both.
- ``nogil=True``: independent files or channels may run in threads.
- ``error_model="numpy"``: a division by zero gives inf/nan (caught by the
  caller's checks) instead of raising inside the loop, which keeps loops tight.
"""

from __future__ import annotations

from typing import Literal, TypedDict

from numba import njit


class JitOptions(TypedDict):
    """The keywords :func:`numba.njit` gets, typed as its signature wants them."""

    cache: bool
    fastmath: bool
    nogil: bool
    error_model: Literal["python", "numpy"]


JIT_OPTIONS: JitOptions = {"cache": True, "fastmath": False, "nogil": True, "error_model": "numpy"}


def kernel(func):
    """Compile ``func`` with the project's options."""
    return njit(**JIT_OPTIONS)(func)


@kernel
def _one_more(x):
    return x + 1.0


def load_target() -> None:
    """Set up Numba's CPU target in this process now (its typing and lowering registries, and SciPy's
    BLAS it looks for: 0.4-0.6 s the first time any kernel is called from the cache): a batch worker
    calls it as it starts, so that its first record costs what the next ones cost."""
    _one_more(1.0)
