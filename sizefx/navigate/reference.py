"""``/reference`` during navigation: read by time window, interpolated at the navigation steps,
and the errors of the solution against it accumulated chunk by chunk."""

from __future__ import annotations

import numpy as np

from ..constants import METRES_PER_NMI, SECONDS_PER_HOUR
from ..io.telemetry import Reference
from ..kernels.errors import compared_steps, navigation_errors
from ..rotation import quat_interp

__all__ = ["reference_at", "vertical_reference_at", "MemoryReference", "Errors"]


def reference_at(ref: Reference, t, attitude: bool = True) -> dict:
    """The reference at times ``t``: ``quat_nb`` (slerp), ``lat``, ``lon``, ``h``, ``v_n`` (linear)."""
    out = {"quat_nb": quat_interp(ref.time_s, ref.quat_nb, t)} if attitude else {}
    if ref.has_position:
        assert ref.lat_rad is not None and ref.lon_rad is not None and ref.height_m is not None  # set together
        out["lat"] = np.interp(t, ref.time_s, ref.lat_rad)
        out["lon"] = np.interp(t, ref.time_s, ref.lon_rad)
        out["h"] = np.interp(t, ref.time_s, ref.height_m)
    if ref.velocity_n_mps is not None:
        out["v_n"] = np.column_stack([np.interp(t, ref.time_s, ref.velocity_n_mps[:, i]) for i in range(3)])
    return out


def vertical_reference_at(ref: Reference, t):
    """The reference's height and down velocity at times ``t`` (linear, as :func:`reference_at`), for
    the vertical channel held to it; the down velocity is None without ``/reference/velocity``.
    Two interpolations instead of :func:`reference_at`'s six: at every navigation step of a flight
    they were 5 % of ``sizefx navigate``'s time."""
    assert ref.height_m is not None  # the vertical channel is held to a reference with a position (choose)
    h = np.interp(t, ref.time_s, ref.height_m)
    vd = None if ref.velocity_n_mps is None else np.interp(t, ref.time_s, ref.velocity_n_mps[:, 2])
    return h, vd


class MemoryReference:
    """A :class:`Reference` in memory behind the interface of
    :class:`sizefx.io.telemetry.ReferenceStream`, so that the navigation loop reads both alike."""

    HEAD_ROWS = 1 << 16  #: the median step is taken over as many rows as the stream takes it

    def __init__(self, ref: Reference):
        self.ref = ref
        self.n = int(ref.time_s.shape[0])
        self.first_s, self.last_s = float(ref.time_s[0]), float(ref.time_s[-1])
        self.has_position = ref.has_position
        self.has_velocity = ref.velocity_n_mps is not None
        self.median_step_s = float(np.median(np.diff(ref.time_s[: self.HEAD_ROWS])))

    def window(self, t_lo: float, t_hi: float) -> Reference:
        """The rows that bracket ``[t_lo, t_hi]``, one more on each side (as the stream's)."""

        def last_at_or_before(t):
            return max(0, int(np.searchsorted(self.ref.time_s, t, side="right")) - 1)

        rows = slice(max(0, last_at_or_before(t_lo) - 1), min(self.n, last_at_or_before(t_hi) + 3))
        r = self.ref

        def pick(x):
            return None if x is None else x[rows]

        return Reference(
            time_s=r.time_s[rows],
            quat_nb=r.quat_nb[rows],
            lat_rad=pick(r.lat_rad),
            lon_rad=pick(r.lon_rad),
            height_m=pick(r.height_m),
            velocity_n_mps=pick(r.velocity_n_mps),
        )

    def summary(self) -> Reference:
        return self.ref


class Errors:
    """Errors against the reference at the navigation steps it has samples at: running final and
    maximum, and the history at the output rows.

    ``ref`` is a :class:`sizefx.io.telemetry.ReferenceStream` or a :class:`MemoryReference`.
    A reference sparser than the solution is compared only where it has samples:
    interpolating it (e.g. 100 Hz through 32 Hz rotor vibration) would be the error shown.
    """

    def __init__(self, ref, approximate: bool, res_dt: float):
        self.ref = ref
        self.approximate = approximate  #: attitude approximate (an importer's note): not compared
        self.sparse = ref is not None and ref.n > 2 and ref.median_step_s > 1.5 * res_dt
        self.res_dt = res_dt
        self.final: dict[str, float] = {}
        self.max: dict[str, float] = {}  #: the largest error so far, beside each final one
        self.history: dict[str, list[np.ndarray]] = {
            k: [] for k in ("time_s", "north_m", "east_m", "horizontal_m", "velocity_mps", "attitude_rad")
        }

    def add(self, t, q, v, lat, lon, out_rows, window):
        """One chunk: navigation steps ``t``, the indices ``out_rows`` of the output rows among them,
        and the reference ``window`` that brackets them."""
        if self.ref is None:
            return
        idx = np.empty(t.size, dtype=np.int64)
        ref_t = window.time_s
        idx = idx[: compared_steps(t, ref_t, self.ref.first_s, self.ref.last_s, self.sparse, 1e-3 * self.res_dt, idx)]
        if idx.size == 0:
            return
        if ref_t.size < 2:  # one reference row: the kernel interpolates between two
            window = _doubled(window)
        none1, none3 = np.zeros(2), np.zeros((2, 3))
        has_pos, has_vel = window.has_position, window.velocity_n_mps is not None
        out = np.empty((idx.size, 7))
        navigation_errors(
            t[idx],
            np.ascontiguousarray(q[idx]),
            np.ascontiguousarray(v[idx]),
            lat[idx],
            lon[idx],
            window.time_s,
            np.ascontiguousarray(window.quat_nb),
            *((window.lat_rad, window.lon_rad, window.height_m) if has_pos else (none1,) * 3),
            np.ascontiguousarray(window.velocity_n_mps) if has_vel else none3,
            has_pos,
            has_vel,
            not self.approximate,
            out,
        )
        is_output = np.zeros(t.size, dtype=bool)
        is_output[out_rows] = True
        hist = is_output[idx]
        self.history["time_s"].append(t[idx][hist])
        if has_pos:
            horiz = out[:, 2]
            self.final["horizontal"] = float(horiz[-1])
            self.max["horizontal"] = max(self.max.get("horizontal", 0.0), float(horiz.max()))
            for name, col in (("north_m", 0), ("east_m", 1), ("horizontal_m", 2)):
                self.history[name].append(out[hist, col])
        if has_vel:
            dv = out[:, 3:6]
            self.final["velocity"] = float(np.linalg.norm(dv[-1]))
            self.history["velocity_mps"].append(dv[hist])
        if not self.approximate:
            att = out[:, 6]
            self.final["attitude"] = float(att[-1])
            self.max["attitude"] = max(self.max.get("attitude", 0.0), float(att.max()))
            self.history["attitude_rad"].append(att[hist])

    def errors(self):
        """The histories (None without a reference)."""
        if self.ref is None:
            return None
        return {k: np.concatenate(v) for k, v in self.history.items() if v}

    def figures(self, duration_s: float) -> dict:
        """The summary's final and maximum errors and the drift over ``duration_s`` [s]; None where the
        reference has nothing to compare with (no position, no velocity, an approximate attitude)."""
        horizontal, velocity, attitude = (self.final.get(k) for k in ("horizontal", "velocity", "attitude"))
        return {
            "final_horizontal_error_m": horizontal,
            "max_horizontal_error_m": None if horizontal is None else self.max["horizontal"],
            "drift_nmi_per_h": None
            if horizontal is None
            else horizontal / METRES_PER_NMI / (duration_s / SECONDS_PER_HOUR),
            "final_velocity_error_mps": velocity,
            "final_attitude_error_deg": None if attitude is None else float(np.degrees(attitude)),
            "max_attitude_error_deg": None if attitude is None else float(np.degrees(self.max["attitude"])),
        }


def _doubled(ref: Reference) -> Reference:
    """A one-row reference as two equal rows one second apart (the same value at every time)."""

    def two(x):
        return None if x is None else np.concatenate([x, x])

    return Reference(
        time_s=np.array([ref.time_s[0], ref.time_s[0] + 1.0]),
        quat_nb=two(ref.quat_nb),
        lat_rad=two(ref.lat_rad),
        lon_rad=two(ref.lon_rad),
        height_m=two(ref.height_m),
        velocity_n_mps=two(ref.velocity_n_mps),
    )
