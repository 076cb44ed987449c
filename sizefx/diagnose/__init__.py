"""What the sensor model gets wrong about a record, named and measured: the ``diagnose`` stage.

Morozov & Bogdanov 2024 fit one effect, the lever arms; diagnose generalises it. From the
record's ``/reference`` motion it predicts what the gyros and accelerometers would read under
the current model (start: the nominal geometry, no delays, no sensor errors; or a model file),
tests every candidate effect against the residual, keeps those the data supports, says what the
record cannot reveal, and measures the gain.

The package, from the bottom up (each module imports only those above it in this list):

- :mod:`.theta`: the model vector ``theta`` (the sensor model's), its layout and units, and an
  effect model as theta;
- :mod:`.reference`: what a record must hold (:class:`DiagnoseError`), the reference motion as
  splines, the usable samples, :func:`crop`;
- :mod:`.predictor`: :mod:`sizefx.sensor_model` evaluated on the reference
  (:func:`predict_readings`) and the measured record next to it (:class:`Predictor`);
- :mod:`.candidates`: the candidate effects and their Jacobian columns (:func:`jacobian_columns`,
  the sensor model's, and :func:`numeric_jacobian`, the slow twin);
- :mod:`.mismatch`: the reference against the IMU, step by step (attitude, velocity or position
  increments), and what ordinary errors explain of the mismatch;
- :mod:`.integrity`: the reference checked against the IMU before any fit (glitches, jumps, gaps);
- :mod:`.algebra`: the algebra of summed normal equations (a fit with parameters pinned, the
  long-run covariance of block scores, the Wald statistic, canonical correlations);
- :mod:`.normal`: rows, block-wise normal equations, the robust (block sandwich) covariance, the
  Wald test, cross-validation, canonical correlations;
- :mod:`.bandwidth`: the band where the reference's derivatives can be trusted;
- :mod:`.selection`: forward selection (information criterion, robust Wald test at a family-wise
  level, cross-validation), what the record cannot reveal and why, the pairs it cannot separate;
- :mod:`.plausibility`: the ranges per sensor grade, the grade inferred from the noise;
- :mod:`.consistency`: the record's parts fitted alone against the stated errors;
- :mod:`.kinds`: the kinds of structure a residual may hold, the size a finding needs, its sentence;
- :mod:`.trends`: the step and trend tests on the residual's block means;
- :mod:`.lines`: the spectral-line test on the residual's Welch spectrum;
- :mod:`.structure`: what stays in the residual (lines, trends, steps, correlation with the motion);
- :mod:`.naming`: each effect found, in its units and in one sentence;
- :mod:`.records`: warnings, rejections and not-revealed entries, as typed records;
- :mod:`.residual`: the residual under one model, span by span, its noise and per-channel measures;
- :mod:`.budget`: the error budget in named parts (white, sandwich, parts, aliases, band);
- :mod:`.holdout`: the gain out of sample (blocked folds in time, other records);
- :mod:`.gauss_newton`: the Gauss-Newton loop, the selection redone each pass;
- :mod:`.judging`: the checks that make a selected effect a finding;
- :mod:`.not_revealed`: the pairs the record cannot tell apart after the fit (resolved by the grade,
  counted as hidden, or named as not revealed with the motions that would separate them);
- :mod:`.fit`: :func:`diagnose` (one record in memory -> :class:`Diagnosis`);
- :mod:`.extended`: the extended model (``sizefx/effects/1``);
- :mod:`.plots`: the residuals before and after, and their spectra;
- :mod:`.report`: the ``sizefx/diagnosis/2`` JSON (and the reader of versions 1 and 2), the text
  report;
- here: the stage as ``sizefx diagnose`` calls it: :class:`DiagnoseConfig`, :func:`run`,
  :class:`DiagnoseResult`; the start model; the navigation before and after.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..configs.diagnose import DiagnoseConfig, one_start_model
from ..effects import IDEAL, load_effects
from ..errors import ConfigError
from ..io.documents import write_json
from ..io.gaps import nominal_period_s
from ..io.telemetry import Telemetry, read_telemetry
from ..io.toml import write_toml
from ..levers import nominal_levers
from ..stage import preflight
from .candidates import CANDIDATES, PRIORITY, Candidate, jacobian_columns, numeric_jacobian
from .fit import MAX_PASSES, Diagnosis, diagnose
from .holdout import HOLDOUT_FOLDS, OVERFIT_ALPHA, OutOfSample, validate_on
from .naming import Effect
from .normal import FOLDS, MAX_ROWS, TARGET_BLOCKS
from .plausibility import GRADES
from .predictor import Predictor, predict_readings
from .records import ModelChecks
from .reference import (
    EDGE_REFERENCE_PERIODS,
    EDGE_S,
    MAX_SAMPLES,
    MIN_REFERENCE_ROWS,
    MIN_SAMPLES,
    REFERENCE_GAP_FACTOR,
    DiagnoseError,
    ReferenceMotion,
    crop,
    require_reference,
)
from .report import (
    DIAGNOSIS_SCHEMA,
    DIAGNOSIS_SCHEMAS,
    PLOT_FILES,
    check_diagnosis,
    format_report,
    model_document,
    model_header,
    model_toml,
    plot,
    read_diagnosis,
    to_json,
)
from .residual import KAPPA_BLOCK_S
from .theta import (
    A_BIAS,
    A_K2,
    A_MIS,
    A_SF,
    CHANNELS,
    G_BIAS,
    G_G,
    G_MIS,
    G_SF,
    LEVER,
    NP,
    PARAMS,
    TAU_A,
    TAU_R,
    TILT,
    Param,
    theta_from_model,
)

__all__ = [
    # the stage
    "DiagnoseConfig",
    "DiagnoseResult",
    "ModelChecks",
    "run",
    "start_model",
    "navigation_gain",
    "NAVIGATION_MIN_S",
    "OutOfSample",
    "validate_on",
    "HOLDOUT_FOLDS",
    "OVERFIT_ALPHA",
    # the library under it
    "diagnose",
    "Diagnosis",
    "Effect",
    "DiagnoseError",
    "crop",
    "ReferenceMotion",
    "Predictor",
    "predict_readings",
    "Candidate",
    "CANDIDATES",
    "PRIORITY",
    "jacobian_columns",
    "numeric_jacobian",
    "format_report",
    "to_json",
    "plot",
    "model_document",
    "model_toml",
    "DIAGNOSIS_SCHEMA",
    "DIAGNOSIS_SCHEMAS",
    "PLOT_FILES",
    "check_diagnosis",
    "read_diagnosis",
    # the model vector
    "Param",
    "PARAMS",
    "NP",
    "theta_from_model",
    "CHANNELS",
    "A_BIAS",
    "A_SF",
    "A_MIS",
    "A_K2",
    "LEVER",
    "TAU_A",
    "TAU_R",
    "TILT",
    "G_BIAS",
    "G_SF",
    "G_MIS",
    "G_G",
    # limits
    "MIN_SAMPLES",
    "MAX_SAMPLES",
    "MAX_ROWS",
    "MIN_REFERENCE_ROWS",
    "EDGE_S",
    "EDGE_REFERENCE_PERIODS",
    "REFERENCE_GAP_FACTOR",
    "FOLDS",
    "TARGET_BLOCKS",
    "KAPPA_BLOCK_S",
    "MAX_PASSES",
    "GRADES",
]

#: Records at least this long, with reference position, are also navigated before and after [s].
NAVIGATION_MIN_S = 600.0


@dataclass(frozen=True)
class DiagnoseResult:
    """What :func:`run` found and wrote, made once at its end. ``report()`` is what ``sizefx diagnose``
    prints."""

    diagnosis: Diagnosis  #: the fit
    start: str  #: what the prediction started from, in words
    document: dict  #: the ``sizefx/diagnosis/2`` document (``plots`` added when plots were written)
    json_path: str | None = None
    plots: list = field(default_factory=list)  #: the PNG files written
    #: what was done with the extended model after the fit: its file, the navigation, other records
    checks: ModelChecks = field(default_factory=ModelChecks)

    @property
    def model_path(self) -> str:
        assert self.checks.model_path is not None  # run() writes the model before it makes the result
        return self.checks.model_path

    def report(self) -> str:
        lines = [format_report(self.diagnosis, self.start, self.checks)]
        if self.json_path:
            lines.append(f"report -> {self.json_path}")
        lines += [f"plot -> {path}" for path in self.plots]
        return "\n".join(lines)

    def to_json(self) -> dict:
        return self.document


def start_model(nominal: str | None = None, model: str | None = None):
    """The model vector the diagnosis starts from, and a phrase saying what it is.

    ``model``: a ``sizefx/effects/1`` TOML (sections it omits are off). Otherwise the
    ``nominal`` geometry (a preset or a ``sizefx/levers/1`` file; default high-precision)
    with no delays and no sensor errors.
    """
    one_start_model(nominal, model)
    if model is not None:
        return theta_from_model(load_effects(model, base=IDEAL)), f"model {model}"
    name = nominal or "high-precision"
    th = np.zeros(NP)
    th[LEVER] = nominal_levers(name).arms_total.ravel()
    return th, f"nominal geometry {name}, no delays, no sensor errors"


def navigation_gain(tel: Telemetry, theta0: np.ndarray, theta: np.ndarray) -> dict | None:
    """Free-inertial horizontal error against ``/reference`` with the start and the extended model.

    Only for navigation-length records (:data:`NAVIGATION_MIN_S` or more, reference with
    position, no IMU gap). The models go to navigation in memory (:func:`model_document`).
    """
    if not _navigable(tel):
        return None
    return {"duration_s": float(tel.duration_s), **_navigation_errors(tel, before=theta0, after=theta)}


def _navigable(tel: Telemetry) -> bool:
    """A navigation-length record with reference position and no IMU gap (navigation cannot bridge
    one; ``diagnose --segment K`` navigates one segment)."""
    if tel.reference is None or not tel.reference.has_position or tel.duration_s < NAVIGATION_MIN_S:
        return False
    return not any(g.dataset.startswith("/imu") for g in tel.gaps)


def _navigation_errors(tel: Telemetry, **models: np.ndarray) -> dict:
    """{name: {"final_m", "max_m"}}: the free-inertial horizontal error of ``tel`` under each model vector."""
    from ..navigate import NavConfig, navigate

    out = {}
    for name, th in models.items():
        model = load_effects(base=IDEAL, overrides=model_document(th))
        errors = navigate(tel, NavConfig(model=model)).errors
        assert errors is not None  # navigate compares with the reference it was given
        err = np.asarray(errors["horizontal_m"])
        out[name] = {"final_m": float(err[-1]), "max_m": float(np.max(err))}
    return out


def _window_navigation(tel: Telemetry, d: Diagnosis, theta0: np.ndarray) -> dict | None:
    """A navigation-length record navigated over each window of its cross-validation
    (:data:`sizefx.diagnose.holdout.NAVIGATION_WINDOWS`) on its own, from the reference at the
    window's start: under the start model, the model fitted without the window, and the model
    fitted to the whole record (:attr:`ModelChecks.window_navigation`); None without them."""
    cv = d.out_of_sample
    if cv is None or not cv.windows or not _navigable(tel):
        return None
    windows = []
    for t0, t1, theta in cv.windows:
        part = crop(tel, t0, t1)
        nav = _navigation_errors(part, before=theta0, after=theta, in_sample=d.theta)
        windows.append({"t0_s": t0, "t1_s": t1, "duration_s": float(part.duration_s), **nav})
    return {"windows": windows}


def run(config: DiagnoseConfig, *, progress=None) -> DiagnoseResult:
    """Diagnose ``config.input``; write the extended model, and the report and plots when asked.

    Pre-flight first (:func:`sizefx.stage.preflight`): the record and any model or levers file
    exist; every output (``--json``, ``--model-out``, each plot) is new or ``force``d, writable,
    and distinct from the others and from every input. ``progress(done, total)`` follows the
    Gauss-Newton passes.
    """
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force, folders={"--plots": config.plots})
    theta0, start = start_model(config.nominal, None if config.model is None else str(config.model))
    path = config.input
    rates = {}  # the --validate-on records, checked before the fit (and read again after it: one at a time)
    for other in config.validate_on:
        tel_o = read_telemetry(other, allow_gaps=config.allow_gaps)
        require_reference(tel_o)
        rates[other] = 1.0 / nominal_period_s(tel_o.time_s)
        del tel_o
    tel = read_telemetry(path, allow_gaps=config.allow_gaps, segment=config.segment)
    require_reference(tel)
    d = diagnose(
        crop(tel, config.from_s, config.to_s),
        theta0,
        bandwidth_hz=config.bandwidth_hz,
        grade=config.grade,
        keep_series=bool(config.plots),
        progress=progress,
    )
    for other, rate_hz in rates.items():  # before anything is written
        if d.bandwidth_hz is not None and not d.bandwidth_hz < 0.4 * rate_hz:
            raise ConfigError(
                f"{other} (--validate-on): the model was fitted below {d.bandwidth_hz:g} Hz, which this "
                f"{rate_hz:g} Hz record cannot resolve (0.8 times its Nyquist frequency: {0.4 * rate_hz:g} Hz); "
                "validate on a record at the rate of the one diagnosed, or diagnose it with a lower --bandwidth-hz"
            )
    inputs = [p for p in config.inputs().values() if p is not None]
    model_out = config.model_out_path
    write_toml(model_out, model_document(d.theta), header=model_header(str(path)), inputs=inputs, force=config.force)
    navigation = windows = None
    if config.navigation:
        navigation = navigation_gain(tel, theta0, d.theta)
        windows = _window_navigation(crop(tel, config.from_s, config.to_s), d, theta0)
    weights = 1.0 / (d.weights_sigma**2 * d.kappa)
    validated = []
    for other in config.validate_on:
        tel_o = read_telemetry(other, allow_gaps=config.allow_gaps)
        nav = navigation_gain(tel_o, theta0, d.theta) if config.navigation else None
        validated.append(validate_on(tel_o, theta0, d.theta, d.bandwidth_hz, weights, navigation=nav))
    checks = ModelChecks(str(model_out), navigation, windows, tuple(validated))
    doc = to_json(d, start, checks)
    if config.json_path:
        write_json(config.json_path, doc, inputs=inputs, force=config.force)
    written = plot(d, config.plots, force=config.force) if config.plots else []
    return DiagnoseResult(
        diagnosis=d,
        start=start,
        document={**doc, "plots": written} if written else doc,  # the file, written before them, has none
        json_path=None if not config.json_path else str(config.json_path),
        plots=written,
        checks=checks,
    )
