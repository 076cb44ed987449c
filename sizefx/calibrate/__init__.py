"""Lever-arm calibration on a turntable (or any record with reference attitude): the ``calibrate`` stage.

Measurement model of accelerometer channel i at time t (the sensor model's, :mod:`sizefx.sensor_model`,
with the arms, a bias, the level tilt and the accelerometer delay):

    a_i = u_i . [ f_grav + omegadot x r_i + omega x (omega x r_i) ] + b_i
          + tilt_i(phi_N, phi_E) + tau (omega x f_grav)_i + noise

- ``f_grav = C_bn (-g_n)``: normal gravity, projected with the reference attitude.
- ``tilt``: the true attitude is R(phi) C_ref. To first order this adds
  ``C_bn (g phi_E, -g phi_N, 0)``.
- ``tau``: the accelerometers read the specific force tau seconds late; to first order
  ``-tau d/dt f_grav = tau omega x f_grav``.

Unknowns: the nine components of r_x, r_y, r_z; a bias per channel and record; the tilt;
optionally tau. Two estimators:

* :func:`per_rotation_fit`: the paper's per-rotation least squares,
  ``H = [1, omega^2, omegadot]`` for each rotation block and horizontal channel
  (Morozov & Bogdanov 2024, section "Calibration"). It ignores the tilt, which
  therefore biases it.
* :func:`joint_fit`: one generalised least squares over every record, on 20 ms interval means
  with the exact mean angular acceleration (no derivative of the gyros), prewhitened by an AR
  model of each channel's noise; its design the sensor model's Jacobian
  (:func:`sizefx.sensor_model.jacobian`), with standard errors, their Cramer-Rao bound, the
  condition number, residual RMS per channel, and an explicit observability check: parameters
  the motion cannot reveal are named instead of inverting a singular matrix (:mod:`.joint`).

The package: :mod:`.records` (a record's rates, angular acceleration and attitude),
:mod:`.per_rotation`, :mod:`.design` (the joint fit's rows: layout, increment domain, design),
:mod:`.noise` (its noise model, whitened normal equations and bound), :mod:`.joint`,
:mod:`.preflight` (what refuses a calibration before the fit), :mod:`.report` (the lines and the
paper's Fig. 6); here the stage,
:class:`CalibrateConfig` -> :func:`run` -> :class:`CalibrateResult`, as ``sizefx calibrate``
calls it::

    from sizefx.calibrate import CalibrateConfig, run
    res = run(CalibrateConfig(("turntable.h5",), json_path="levers.json"))
    print(res.report())
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..configs.calibrate import CalibrateConfig
from ..constants import ARCSEC
from ..geometry import triad_point
from ..io.telemetry import read_telemetry
from ..levers import Levers, nominal_levers, write_levers
from ..stage import preflight as stage_preflight
from .joint import BIAS_WINDOW_S, PARAMS_R, UNDETERMINED_SIGMA, UNOBSERVABLE_EIG, CalibrationResult, joint_fit
from .per_rotation import VERTICAL_WITHIN_RAD, detect_rotations, per_rotation_fit
from .preflight import PREFLIGHT_ROWS, Excitation, excitation, preflight
from .records import (
    MIN_SAMPLES,
    ROTATING_RAD_S,
    SPLINE_REFERENCE_STEPS,
    CalibrationError,
    Record,
    prepare,
    reference_attitude,
)
from .report import compensation_figure, report_lines

__all__ = [
    "CalibrationError",
    "Record",
    "prepare",
    "per_rotation_fit",
    "joint_fit",
    "detect_rotations",
    "CalibrationResult",
    "Excitation",
    "excitation",
    "preflight",
    "run",
    "CalibrateConfig",
    "CalibrateResult",
    "format_report",
    "compensation_figure",
    "nominal_levers",
    "reference_attitude",
    "MIN_SAMPLES",
    "ROTATING_RAD_S",
    "UNOBSERVABLE_EIG",
    "BIAS_WINDOW_S",
    "UNDETERMINED_SIGMA",
    "PARAMS_R",
    "SPLINE_REFERENCE_STEPS",
    "VERTICAL_WITHIN_RAD",
    "PREFLIGHT_ROWS",
]


@dataclass
class CalibrateResult:
    """What a calibration found (:attr:`fit`, :attr:`levers`) and wrote (:attr:`written`)."""

    levers: Levers  #: the arms r_i, split at the triad point into r and d_i, with everything in ``extra``
    fit: CalibrationResult  #: the joint fit
    per_rotation: dict  #: record name -> the paper's per-rotation fits
    nominal: Levers
    records: list  #: the :class:`Record` of every segment fitted
    skipped: list = field(default_factory=list)  #: segments too short to fit
    figure_spans: list | None = None  #: peak-to-peak per block and channel of ``--plot``
    written: dict = field(default_factory=dict)  #: option -> path of each file written

    def report(self) -> str:
        """The lines ``sizefx calibrate`` prints."""
        lines = report_lines(self.fit, self.nominal, self.levers, self.records, self.skipped, self.per_rotation)
        if "--json" in self.written:
            lines.append(f"lever arms -> {self.written['--json']}")
        if "--plot" in self.written:
            lines.append(f"figure -> {self.written['--plot']}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The ``sizefx/levers/1`` document (with the fit's figures in its extra keys) and the files written."""
        return {
            "levers": self.levers.to_json(),
            "figure_spans": self.figure_spans,
            "written": {k: str(v) for k, v in self.written.items()},
        }


def format_report(out: CalibrateResult) -> str:
    """The report of a :class:`CalibrateResult`."""
    return "\n".join(report_lines(out.fit, out.nominal, out.levers, out.records, out.skipped, out.per_rotation))


def run(config: CalibrateConfig, *, progress=None) -> CalibrateResult:
    """The ``calibrate`` stage: pre-flight, fits, decomposition, report figures; writes the lever arms
    (``json_path``, sizefx/levers/1) and the figure (``plot``) when asked.

    Everything that can refuse the run is checked before the first record is read whole: the
    options, the files (:func:`sizefx.stage.preflight`: inputs exist, outputs writable and
    distinct from them), the nominal geometry, each record's reference and site, and the
    motion's excitation of the arms (:func:`preflight`). ``progress(done, total)`` is called
    as the records are read.
    """
    paths = [str(p) for p in config.records]
    if not paths:
        raise CalibrationError("no record given; give one or more telemetry files with /reference attitude")
    if len({Path(p).resolve() for p in paths}) != len(paths):
        raise CalibrationError("a record is given twice; give each record once")
    stage_preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    nom = nominal_levers(config.nominal)
    preflight(paths, with_delay=config.with_delay, allow_gaps=config.allow_gaps)
    records, skipped = [], []
    for k, p in enumerate(paths):
        pieces = read_telemetry(p, allow_gaps=config.allow_gaps).continuous_pieces()
        for seg, piece in pieces:
            name = p if len(pieces) == 1 else f"{p} segment {seg.number}/{seg.of}"
            if piece.n_samples < MIN_SAMPLES:
                skipped.append(f"{name} ({piece.n_samples} samples)")
                continue
            records.append(prepare(piece, name))
        if progress is not None:
            progress(k + 1, len(paths))
    per_rotation = {rec.name: per_rotation_fit(rec) for rec in records}
    res = joint_fit(records, with_tilt=config.with_tilt, with_delay=config.with_delay)
    assert res.bound_sigma is not None  # joint_fit sets it
    point = triad_point(res.arms, how=config.triad)
    sigma_tilt = None if res.sigma_tilt_rad is None else (res.sigma_tilt_rad / ARCSEC).tolist()
    levers = Levers(
        arms_total=res.arms,
        offset=point,
        arms_triad=res.arms - point,
        sigma=res.sigma_arms,
        reference_point="rotation-center",
        tilt_arcsec=None if res.tilt_rad is None else (res.tilt_rad / ARCSEC).tolist(),
        accel_delay_s=res.delay_s,
        extra={
            "triad_point": config.triad,
            "sigma_tilt_arcsec": sigma_tilt,
            "sigma_accel_delay_s": res.sigma_delay_s,
            "bound_sigma": res.bound_arms.tolist(),
            "bound_sigma_tilt_arcsec": None
            if res.tilt_rad is None
            else (res.bound_sigma[res.names.index("tilt_north") :][:2] / ARCSEC).tolist(),
            "bound_sigma_accel_delay_s": float(res.bound_sigma[-1]) if res.delay_s is not None else None,
            "sigma_accel_bias_windows_mps2": res.bias_windows().tolist(),
            "bound_accel_bias_windows_mps2": res.bias_windows(res.bound_sigma).tolist(),
            "interval_s": res.interval_s,
            "noise_model": res.noise,
            "left_out_steps": res.left_out_steps,
            "left_out_s": res.left_out_s,
            "accel_bias_mps2": res.biases.tolist(),
            "condition_number": res.condition,
            "residual_rms_mps2": res.residual_rms.tolist(),
            "samples": res.samples,
            "nominal": config.nominal,
            "difference_from_nominal_m": (res.arms - nom.arms_total).tolist(),
            "per_rotation": per_rotation,
            "records": paths,
            "segments": [rec.name for rec in records],
            "segments_too_short": skipped,
        },
    )
    out = CalibrateResult(
        levers=levers, fit=res, per_rotation=per_rotation, nominal=nom, records=records, skipped=skipped
    )
    if config.plot:
        with_blocks = [k for k, rec in enumerate(records) if detect_rotations(rec)]
        if not with_blocks:
            raise CalibrationError("--plot draws rotation blocks about vertical axes, and none of the records has one")
        k = with_blocks[0]
        out.figure_spans = compensation_figure(
            records[k], levers, config.plot, title=f"{Path(records[k].name).name}: size effect before and after"
        )
        out.written["--plot"] = str(config.plot)
    if config.json_path:
        write_levers(config.json_path, levers, inputs=paths, force=config.force)
        out.written["--json"] = str(config.json_path)
    return out
