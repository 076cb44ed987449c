"""The package list, discovered: every package under ./sizefx, plus the two renamed folders.

Everything else (metadata, dependencies, the folder mapping) is in pyproject.toml. A list
written by hand once left ``sizefx.kernels`` out of the wheel; here a new subpackage is found
by ``find_packages`` and tests/test_packaging.py checks the built wheel file by file.
"""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["sizefx", "sizefx.*"]), "sizefx_cli", "sizefx.schemas"])
