"""Exception classes of sizefx.

Every error a user can cause (a bad file, a bad option, an unobservable
calibration) is a :class:`SizefxError`. Its message is one line that says what
was found, where, and how to fix it; the CLI prints it and exits with code 2.
"""

from __future__ import annotations

__all__ = [
    "SizefxError",
    "TelemetryError",
    "ConfigError",
    "OutputError",
    "SourceError",
    "UnitsError",
    "Interrupted",
]


class SizefxError(Exception):
    """Base class of all user-facing errors of sizefx."""

    exit_code = 2


class TelemetryError(SizefxError):
    """A telemetry file violates the ``sizefx/telemetry/1`` contract.

    Parameters
    ----------
    path : str
        The file.
    dataset : str
        The HDF5 object concerned (``"/imu/time"``, ``"/"`` for the root).
    problem : str
        What is wrong and, where possible, how to fix it.
    """

    def __init__(self, path, dataset: str, problem: str):
        self.path = str(path)
        self.dataset = dataset
        self.problem = problem
        super().__init__(f"{self.path}: {dataset}: {problem}")


class ConfigError(SizefxError):
    """A configuration (effects TOML, option value) is invalid."""


class OutputError(SizefxError):
    """An output cannot be written as asked (exists, is an input, ...)."""


class SourceError(SizefxError):
    """A file to import is not what its format promises (missing column, truncated, bad units)."""

    def __init__(self, path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class UnitsError(SizefxError):
    """Data whose magnitudes contradict their declared units (:mod:`sizefx.sanity`).

    Parameters
    ----------
    path : str
        The file (the source of an import, or the telemetry file).
    where : str
        The dataset or columns concerned (``"/imu/gyro"``, ``"gyro columns gx, gy, gz"``).
    problem : str
        The figures, the unit the data look like, and how to fix it.
    """

    def __init__(self, path, where: str, problem: str):
        self.path = str(path)
        self.where = where
        self.problem = problem
        super().__init__(f"{self.path}: {where}: {problem}")


class Interrupted(BaseException):
    """SIGINT or SIGTERM (``signum``) arrived: raised in the main thread so that every ``finally`` and
    temporary-file clean-up runs; the command line exits with 128 + ``signum``. A BaseException,
    as KeyboardInterrupt is: no ``except Exception`` may swallow it."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        super().__init__(f"signal {self.signum}")
