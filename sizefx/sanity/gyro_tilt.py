"""Check (c) of :mod:`sizefx.sanity`: the gyros against the tilt the accelerometers see.

Without a reference: between two quasi-static moments (``|f|`` at its usual value, so ``f`` is
``-g`` in body axes) whose gravity directions differ by at least
:data:`~sizefx.sanity.thresholds.TILT_MIN_RAD`, the gyros, integrated under each unit hypothesis,
must carry the first direction onto the second. The hypothesis that explains the tilt changes (and
that alone) says which unit the data are in.
"""

from __future__ import annotations

import numpy as np

from ..constants import DEG
from ..io.schema import TELEMETRY_SCHEMA, load_schema, unit_factor
from ..rotation import rotvec_to_mat
from .thresholds import (
    QUASI_STATIC_TOL,
    TILT_BLOCKS,
    TILT_MATCH,
    TILT_MAX_PAIRS,
    TILT_MIN_PAIRS,
    TILT_MIN_RAD,
    TILT_PAIR_MAX_S,
    TILT_REJECT,
    TILT_SCALE_GRID,
)
from .verdict import FORM_QUANTITIES, Check
from .windows import _Windows

# nothing public: these helpers are imported by name within sizefx.sanity
__all__: list[str] = []


def _angle(u, v):
    """Angle [rad] between unit vectors (last axis)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def _tilt_pairs(win: _Windows, gaps_s) -> list[tuple[int, int]]:
    norms = np.linalg.norm(win.f_b, axis=1)
    if norms.size < 2:
        return []
    typical = float(np.median(norms))
    quasi = np.flatnonzero(np.abs(norms / typical - 1.0) <= QUASI_STATIC_TOL)
    u = win.f_b / np.maximum(norms, 1e-300)[:, None]
    tc = win.t_center
    pairs = []
    k = 0
    while k < quasi.size - 1:
        i = quasi[k]
        later = quasi[k + 1 :]
        later = later[tc[later] - tc[i] <= TILT_PAIR_MAX_S]
        moved = later[_angle(u[i], u[later]) >= TILT_MIN_RAD]
        if moved.size == 0:
            k += 1
            continue
        j = int(moved[0])
        if not any(tc[i] <= g < tc[j] for g in gaps_s):
            pairs.append((int(i), j))
        k = int(np.searchsorted(quasi, j))
    if len(pairs) > TILT_MAX_PAIRS:
        pick = np.linspace(0, len(pairs) - 1, TILT_MAX_PAIRS).round().astype(int)
        pairs = [pairs[p] for p in pick]
    return pairs


def _check_gyro_tilt(tel, win: _Windows, period: float, dataset: str, declared: str) -> Check | str:
    """(c); a reason string when no verdict is possible."""
    gaps_s = [g.time_s for g in tel.gaps if g.dataset.startswith("/imu")]
    pairs = _tilt_pairs(win, gaps_s)
    if len(pairs) < TILT_MIN_PAIRS:
        return (
            f"no tilt: the gravity direction moves by {TILT_MIN_RAD / DEG:.0f} deg within "
            f"{TILT_PAIR_MAX_S:g} s {len(pairs)} times (needs {TILT_MIN_PAIRS})"
        )
    quantity = FORM_QUANTITIES[tel.form][0]
    base = unit_factor(quantity, declared)
    table = load_schema(TELEMETRY_SCHEMA)["units"][quantity]
    hypotheses = [declared] + [u for u in table if u != declared]
    # data read as `declared` are (true value) x factor(declared) / factor(u) if they are in u
    scales = np.array([table[u] / base for u in hypotheses])
    candidates = (scales[:, None] * TILT_SCALE_GRID[None, :]).ravel()  # [H * G]
    # The gyro bias read at rest is removed (a raw MEMS reads 0.6 deg/s, 6 deg over 10 s); but a
    # record may only seem to rest (a table turning about the vertical keeps f steady), so each
    # hypothesis is also tried without it, and the better of the two counts.
    biases = [np.zeros(3)] + ([np.median(win.omega_b[win.rest], axis=0)] if win.rest.any() else [])
    t = tel.time_s
    g, _ = tel.imu_arrays()
    norms = np.linalg.norm(win.f_b, axis=1)
    u = win.f_b / norms[:, None]
    u_i = np.array([u[i] for i, _ in pairs])
    u_j = np.array([u[j] for _, j in pairs])
    errors = []
    for bias in biases:
        blocks = np.zeros((len(pairs), TILT_BLOCKS, 3))
        for p, (i, j) in enumerate(pairs):
            r0, r1 = (int(np.searchsorted(t, win.t_center[x])) for x in (i, j))
            if tel.form == "rates":
                incr = (g[r0:r1] - bias) * np.diff(t[r0 : r1 + 1])[:, None]
            else:
                incr = g[r0 + 1 : r1 + 1] - bias * period
            cum = np.vstack([np.zeros(3), np.cumsum(incr, axis=0)])
            edges = np.linspace(0, incr.shape[0], TILT_BLOCKS + 1).round().astype(int)
            blocks[p] = cum[edges[1:]] - cum[edges[:-1]]
        # mat[p, c] maps body vectors at the second moment to body axes at the first
        mat = np.broadcast_to(np.eye(3), (len(pairs), candidates.size, 3, 3)).copy()
        for b in range(TILT_BLOCKS):
            mat = mat @ rotvec_to_mat(candidates[None, :, None] * blocks[:, None, b, :])
        predicted = np.einsum("pcji,pj->pci", mat, u_i)  # gravity fixed in NED: u_j = mat^T u_i
        errors.append(_angle(predicted, u_j[:, None, :]))  # [P, C]
    tilt = _angle(u_i, u_j)  # [P] rad
    # residual as a fraction of the tilt change, median over the pairs: [H, G]
    residual = np.min([np.median(e / tilt[:, None], axis=0) for e in errors], axis=0).reshape(len(hypotheses), -1)
    centre = TILT_SCALE_GRID.size // 2
    at_hypothesis = residual[:, centre]
    best = int(np.argmin(at_hypothesis))
    others = np.delete(at_hypothesis, best)
    count = len(pairs)
    tilts = tilt / DEG
    if at_hypothesis[best] > TILT_MATCH or np.any(others < TILT_REJECT):
        return (
            f"the {count} tilt changes ({min(tilts):.0f}-{max(tilts):.0f} deg) fit no unit clearly (median "
            f"residual / tilt: {', '.join(f'{h} {r:.2f}' for h, r in zip(hypotheses, at_hypothesis))})"
        )
    fitted = scales[best] * TILT_SCALE_GRID[int(np.argmin(residual[best]))]
    ratio = 1.0 / fitted  # data as read / truth, as in (b)
    if best == 0:
        return Check(
            "gyro",
            dataset,
            declared,
            "ok",
            f"gyro against the tilt the accelerometers see: ratio {ratio:.3f}, median residual "
            f"{100 * at_hypothesis[0]:.1f} % over {count} tilt changes of {min(tilts):.0f}-"
            f"{max(tilts):.0f} deg",
            "tilt",
            ratio,
            count,
        )
    detail = (
        f"explains the {count} tilt changes the accelerometers see ({min(tilts):.0f}-{max(tilts):.0f} deg) "
        f"only when read as '{hypotheses[best]}' (median residual {100 * at_hypothesis[best]:.0f} % of the tilt; "
        f"as '{declared}' {100 * at_hypothesis[0]:.0f} %): it integrates to {ratio:.4g} times the tilt"
    )
    return Check("gyro", dataset, declared, "wrong", detail, "tilt", ratio, count, hypotheses[best])
