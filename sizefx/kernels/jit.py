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
