"""The files a navigation run writes: the ``sizefx/navigation/1`` solution and the error plot."""

from __future__ import annotations

import contextlib
import json

import h5py
import numpy as np

from .. import __version__
from ..errors import ConfigError
from ..io.files import atomic_output
from ..rotation import mat_to_euler, quat_to_mat
from .result import NavResult

__all__ = ["write_navigation", "NavigationWriter", "plot_errors"]


def write_navigation(path, res: NavResult, *, input_file, force: bool = False):
    """Write ``sizefx/navigation/1`` atomically, decimated to ``output_rate_hz``."""
    rate = res.config.get("output_rate_hz")
    stride = 1
    if rate and not res.config.get("streamed"):  # a streamed result holds the output rows already
        stride = max(1, int(round(res.config["nav_rate_hz"] / rate)))
    sel = slice(stride - 1, None, stride)
    roll, pitch, heading = mat_to_euler(quat_to_mat(res.quat_nb[sel]))
    with atomic_output(path, inputs=[input_file], force=force) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["schema"] = "sizefx/navigation/1"
        h5.attrs["input_file"] = str(input_file)
        h5.attrs["configuration_json"] = json.dumps(res.config, default=float)
        h5.attrs["summary_json"] = json.dumps(res.summary, default=float)
        h5.attrs["sizefx_version"] = __version__
        h5.create_dataset("time", data=res.time_s[sel]).attrs["units"] = "s"
        h5.create_dataset("position", data=np.column_stack([np.degrees(res.lat_rad[sel]), np.degrees(res.lon_rad[sel]),
                                                            res.height_m[sel]])).attrs["units"] = "deg,deg,m"
        h5.create_dataset("velocity", data=res.v_n[sel]).attrs["units"] = "m/s"
        h5.create_dataset("quaternion", data=res.quat_nb[sel]).attrs["units"] = "1"
        h5.create_dataset("euler", data=np.column_stack([np.degrees(roll), np.degrees(pitch),
                                                         np.degrees(heading) % 360.0])).attrs["units"] = "deg"


class NavigationWriter:
    """``sizefx/navigation/1`` written row block by row block, atomically (a streamed run's output).

    The rows go to resizable datasets of a temporary file; :meth:`close` adds the
    configuration and summary and renames it into place, :meth:`abort` removes it.
    """

    def __init__(self, path, *, input_file, force: bool = False):
        self._ctx = atomic_output(path, inputs=[input_file], force=force)
        tmp = self._ctx.__enter__()
        try:
            self.h5 = h5py.File(tmp, "w")
            self.h5.attrs["schema"] = "sizefx/navigation/1"
            self.h5.attrs["input_file"] = str(input_file)
            self.h5.attrs["sizefx_version"] = __version__
            self._sets = {}
            for name, width, units in (("time", None, "s"), ("position", 3, "deg,deg,m"), ("velocity", 3, "m/s"),
                                       ("quaternion", 4, "1"), ("euler", 3, "deg")):
                shape, maxshape = ((0,), (None,)) if width is None else ((0, width), (None, width))
                chunks = (1 << 14,) if width is None else (1 << 14, width)
                dset = self.h5.create_dataset(name, shape=shape, maxshape=maxshape, chunks=chunks, dtype="f8")
                dset.attrs["units"] = units
                self._sets[name] = dset
        except BaseException as exc:
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self.rows = 0

    def append(self, time_s, lat_rad, lon_rad, height_m, v_n, quat_nb):
        if len(time_s) == 0:
            return
        roll, pitch, heading = mat_to_euler(quat_to_mat(quat_nb))
        block = {"time": time_s,
                 "position": np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), height_m]),
                 "velocity": v_n, "quaternion": quat_nb,
                 "euler": np.column_stack([np.degrees(roll), np.degrees(pitch), np.degrees(heading) % 360.0])}
        n0, n1 = self.rows, self.rows + len(time_s)
        for name, data in block.items():
            dset = self._sets[name]
            dset.resize(n1, axis=0)
            dset[n0:n1] = data
        self.rows = n1

    def close(self, config: dict, summary: dict):
        self.h5.attrs["configuration_json"] = json.dumps(config, default=float)
        self.h5.attrs["summary_json"] = json.dumps(summary, default=float)
        self.h5.close()
        self._ctx.__exit__(None, None, None)

    def abort(self, exc: BaseException):
        self.h5.close()
        with contextlib.suppress(type(exc)):
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)


def plot_errors(res: NavResult, png, title: str):
    """Horizontal (and north, east) error against the reference versus time, PNG."""
    import matplotlib  # here, not at module level: it costs start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if res.errors is None or "horizontal_m" not in res.errors:
        raise ConfigError("no reference position to plot errors against")
    t_min = (res.errors["time_s"] - res.time_s[0]) / 60.0
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    ax.plot(t_min, res.errors["horizontal_m"], label="horizontal")
    ax.plot(t_min, res.errors["north_m"], lw=0.8, label="north")
    ax.plot(t_min, res.errors["east_m"], lw=0.8, label="east")
    ax.set_xlabel("time since start [min]")
    ax.set_ylabel("position error [m]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
