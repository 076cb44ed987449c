"""What the delimited-text importers share (:mod:`sizefx.importers.table`, its reference side
:mod:`sizefx.importers.table_reference`, and :mod:`sizefx.importers.table_log`): the text table read
with its header, whose errors name the file's line and the option of the column (``_Table``), the
units of a time column and the check that they give a plausible rate (:data:`TIME_UNITS`,
``_time_units_problem``), and a column option checked to name its columns (``_columns``)."""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SourceError
from . import median_rate_hz

__all__ = ["TIME_UNITS"]

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def _time_units_problem(column: str, option: str, units: str, units_option: str, time_s, rate_range_hz, what: str):
    """What is wrong with the unit of a time column whose stamps (``time_s``, in s after ``units``) imply a
    sample rate outside ``rate_range_hz``, naming the column and the unit option, and the unit that would
    give a plausible rate; None when the rate is plausible (or the stamps do not increase: the time checks
    refuse those)."""
    rate_hz = median_rate_hz(time_s)
    lo, hi = rate_range_hz
    if rate_hz is None or lo <= rate_hz <= hi:
        return None
    read_as = f"in {units}" if units in TIME_UNITS else "as a sample counter"
    found = f"the time column '{column}' ({option}) implies {rate_hz:.3g} Hz {read_as}, outside the {lo:g}..{hi:g} Hz"
    if units not in TIME_UNITS:  # a sample counter: its step, not a unit, sets the rate
        return f"{found} {what}; check --rate-hz (per counter step) or give the column's time unit ({units_option})"
    # the plausible unit nearest the one given (ms before us when s was given)
    given = TIME_UNITS[units]
    plausible = [
        (abs(np.log(factor / given)), unit, rate_hz * given / factor)
        for unit, factor in TIME_UNITS.items()
        if unit != units and lo <= rate_hz * given / factor <= hi
    ]
    if not plausible:
        return f"{found} {what} in any of {', '.join(TIME_UNITS)}; check the column is the time"
    _, unit, rate_then_hz = min(plausible)
    return f"{found} {what}; in {unit} it would be {rate_then_hz:.3g} Hz: give {units_option} {unit}"


# --------------------------------------------------------------------------- reading text


@dataclass
class _Table:
    """A delimited text file: its lines and stripped header names."""

    path: Path
    lines: list
    header: list
    delimiter: str

    @classmethod
    def read(cls, path: Path, delimiter: str, what: str = "file") -> _Table:
        try:
            text = Path(path).read_text("utf-8-sig")  # -sig: a spreadsheet's byte-order mark is not a name
        except UnicodeDecodeError:
            raise SourceError(path, f"{what} is not a text file") from None
        lines = text.splitlines()
        header = [h.strip() for h in lines[0].split(delimiter)] if lines else []
        return cls(Path(path), lines, header, delimiter)

    def require(self, names, option_of: dict):
        """Every column of ``names`` is in the header, or an error naming the first missing one and its option."""
        missing = [c for c in names if c not in self.header]
        if missing:
            raise SourceError(
                self.path,
                f"column '{missing[0]}' is not in the header ({option_of[missing[0]]}); "
                f"columns are: {', '.join(self.header)}",
            )

    @staticmethod
    def is_data(line: str) -> bool:
        """What :func:`numpy.loadtxt` reads as a row: not blank once a ``#`` comment is cut."""
        return bool(line.split("#", 1)[0].strip())

    def line_number(self, row: int) -> int:
        """File line (1-based, the header is line 1) of data row ``row``."""
        k = -1
        for number, line in enumerate(self.lines[1:], start=2):
            if self.is_data(line):
                k += 1
                if k == row:
                    return number
        return len(self.lines)

    def numbers(self, names, option_of: dict, *, empty_is_nan: bool = False) -> np.ndarray:
        """Columns ``names`` as float64 ``[rows, len(names)]``; empty cells NaN if ``empty_is_nan``.

        Fast path :func:`numpy.loadtxt`; on failure a line-by-line scan names the bad cell.
        """
        idx = [self.header.index(c) for c in names]
        body = "\n".join(self.lines[1:])
        converters: dict[int | str, Callable[[str], float]] | None = None
        if empty_is_nan:
            converters = {i: (lambda s: float(s) if s.strip() else np.nan) for i in set(idx)}
        try:
            return np.loadtxt(io.StringIO(body), delimiter=self.delimiter, ndmin=2, usecols=idx, converters=converters)
        except ValueError as exc:
            self._raise_bad_cell(names, idx, option_of, empty_is_nan)
            detail = " ".join(str(exc).split())[:100]
            raise SourceError(self.path, f"a data row is not numeric or has too few columns ({detail})") from None

    def _raise_bad_cell(self, names, idx, option_of, empty_is_nan):
        need = max(idx) + 1
        for number, line in enumerate(self.lines[1:], start=2):
            if not self.is_data(line):
                continue
            fields = line.split("#", 1)[0].split(self.delimiter)
            if len(fields) < need:
                raise SourceError(
                    self.path,
                    f"line {number} has {len(fields)} fields, the header {len(self.header)}; "
                    f"column '{names[idx.index(max(idx))]}' is missing there (write empty "
                    "cells with their delimiters)",
                )
            for name, i in zip(names, idx):
                cell = fields[i].strip()
                if not cell:
                    if empty_is_nan:
                        continue
                    raise SourceError(
                        self.path,
                        f"column '{name}' ({option_of[name]}) is empty on line {number}; "
                        "IMU cells must all be filled (give a reference with rows of its "
                        "own in --reference-file)",
                    )
                try:
                    float(cell)
                except ValueError:
                    raise SourceError(
                        self.path,
                        f"column '{name}' ({option_of[name]}) on line {number} holds "
                        f"'{cell[:20]}', which is not numeric",
                    ) from None


# --------------------------------------------------------------------------- options


def _columns(path, cols, option: str, n: int, names: str):
    cols = tuple(c.strip() for c in cols)
    if len(cols) != n:
        raise SourceError(
            path,
            f"{option} names {len(cols)} columns ({', '.join(cols)}); give exactly {('three', 'four')[n - 3]}, {names}",
        )
    return cols
