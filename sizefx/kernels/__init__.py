"""Numba kernels: arrays and scalars in, arrays out; no I/O, no printing, no click.

Each kernel has a slow NumPy/Python twin in ``tests/naive.py`` and a test
comparing them. JIT options are set once, in :mod:`sizefx.kernels.jit`.
"""
