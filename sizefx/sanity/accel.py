"""Check (a) of :mod:`sizefx.sanity`: the accelerometers against gravity.

Where the record rests, ``|f|`` is local gravity (normal gravity at the site, else standard
gravity) within :data:`~sizefx.sanity.thresholds.ACCEL_BAND`; a record that never rests is judged on
the median ``|f|`` of all its windows, within the wider
:data:`~sizefx.sanity.thresholds.ACCEL_MOVING_BAND`.
"""

from __future__ import annotations

import numpy as np

from .. import earth
from ..constants import STANDARD_GRAVITY_MPS2
from .thresholds import ACCEL_BAND, ACCEL_MOVING_BAND, WINDOW_S
from .verdict import FORM_QUANTITIES, Check, looks_like
from .windows import _Windows

# nothing public: these helpers are imported by name within sizefx.sanity
__all__: list[str] = []


def _gravity(tel) -> tuple[float, str]:
    """Magnitude of gravity [m/s^2] where the record was made, and how it was known."""
    site = tel.site
    ref = tel.reference
    if site is not None:
        return float(earth.gravity_n(site.lat_rad, site.height_m)[2]), "normal gravity at the site"
    if ref is not None and ref.has_position:
        return float(earth.gravity_n(ref.lat_rad[0], ref.height_m[0])[2]), "normal gravity at the reference position"
    return STANDARD_GRAVITY_MPS2, "standard gravity (no site in the file)"


def _check_accel(tel, win: _Windows, dataset: str, declared: str) -> Check:
    quantity = FORM_QUANTITIES[tel.form][1]
    g, where = _gravity(tel)
    norms = np.linalg.norm(win.f_b, axis=1)
    if win.rest.any():
        method, band, sel = "rest", ACCEL_BAND, win.rest
        label = "specific force at rest"
    elif norms.size:
        method, band, sel = "motion", ACCEL_MOVING_BAND, np.ones(norms.size, bool)
        label = "specific force (no rest found; median of all windows)"
    else:
        return Check(
            "accel",
            dataset,
            declared,
            "unchecked",
            f"specific force: not checked: the record is shorter than one {WINDOW_S} s window",
        )
    value = float(np.median(norms[sel]))
    count = int(sel.sum())
    ratio = value / g
    figures = (
        f"{label} {value:.4g} m/s^2 against {where} {g:.4f} (ratio {ratio:.3f}, {count} windows of {WINDOW_S:g} s)"
    )
    if 1.0 / band <= ratio <= band:
        return Check("accel", dataset, declared, "ok", figures, method, ratio, count)
    unit = looks_like(quantity, declared, ratio, band)
    state = "at rest" if method == "rest" else "in motion (no rest found)"
    detail = (
        f"reads {value:.4g} m/s^2 {state} after converting from '{declared}' (median of {count} windows), "
        f"{ratio:.4g} times {where} {g:.4f} m/s^2"
    )
    return Check("accel", dataset, declared, "wrong", detail, method, ratio, count, unit)
