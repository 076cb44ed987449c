"""Numba kernels: arrays and scalars in, arrays out; no I/O, no printing, no click.

- :mod:`~sizefx.kernels.sync`: not-a-knot cubic spline resampling (accelerometers onto the
  gyro time base), of samples and of increments;
- :mod:`~sizefx.kernels.omegadot`: Savitzky-Golay first derivative (angular acceleration);
- :mod:`~sizefx.kernels.sizeeffect`: the size-effect compensation, rates and increments;
- :mod:`~sizefx.kernels.increments`: rates to increments;
- :mod:`~sizefx.kernels.strapdown` and :mod:`~sizefx.kernels.earth`: the navigation.

Each kernel has a slow NumPy/Python twin in ``tests/naive.py`` and a test
comparing them. JIT options are set once, in :mod:`sizefx.kernels.jit`.
"""
