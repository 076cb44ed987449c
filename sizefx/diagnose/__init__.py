"""What the simulation of a record gets wrong, named and measured: the ``diagnose`` stage.

Morozov & Bogdanov 2024 fit one effect, the lever arms; diagnose generalises it. From the
record's ``/reference`` motion it predicts what the gyros and accelerometers would read under
the current model (start: the nominal geometry, no delays, no sensor errors; or a model file),
tests every candidate effect against the residual, keeps those the data supports, says what the
record cannot reveal, and measures the gain.

The package, from the bottom up (each module imports only those above it in this list):

- :mod:`.theta`: the model vector ``theta``, its layout and units, and an effect model as theta;
- :mod:`.reference`: what a record must hold (:class:`DiagnoseError`), the reference motion as
  splines, the usable samples, :func:`crop`;
- :mod:`.predictor`: the sensor model on the reference (:func:`predict_readings`) and the
  measured record next to it (:class:`Predictor`);
- :mod:`.candidates`: the candidate effects and their Jacobian columns (:func:`jacobian_columns`,
  and :func:`numeric_jacobian`, the slow twin);
- :mod:`.selection`: normal equations, forward selection with an information criterion and
  cross-validation, what the record cannot reveal and why;
- :mod:`.naming`: each effect found, in its units and in one sentence;
- :mod:`.fit`: the Gauss-Newton loop, :func:`diagnose` (one record in memory -> :class:`Diagnosis`);
- :mod:`.report`: the extended model (``sizefx/effects/1``), the ``sizefx/diagnosis/1`` JSON, the
  text report, the plots;
- here: :func:`run`, as ``sizefx diagnose`` calls it; the start model; the navigation before and after.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..effects import IDEAL, load_effects
from ..errors import ConfigError
from ..io.files import atomic_output, check_output_path
from ..io.telemetry import Telemetry, read_telemetry
from ..io.toml import write_toml
from .candidates import CANDIDATES, PRIORITY, Candidate, jacobian_columns, numeric_jacobian
from .fit import KAPPA_BLOCK_S, MAX_PASSES, Diagnosis, diagnose
from .naming import Effect
from .predictor import Predictor, predict_readings
from .reference import (EDGE_REFERENCE_PERIODS, EDGE_S, MAX_SAMPLES, MIN_REFERENCE_ROWS, MIN_SAMPLES,
                        REFERENCE_GAP_FACTOR, DiagnoseError, ReferenceMotion, crop, require_reference)
from .report import (DIAGNOSIS_SCHEMA, PLOT_FILES, format_report, model_document, model_header, model_toml, plot,
                     to_json)
from .selection import FOLD_BLOCK_S, FOLDS, MAX_ROWS
from .theta import (A_BIAS, A_K2, A_MIS, A_SF, CHANNELS, DEG_PER_H, G_BIAS, G_G, G_MIS, G_SF, LEVER, NP, PARAMS, TAU_A,
                    TAU_R, TILT, UG, Param, theta_from_model)

__all__ = [
    # the stage
    "run", "start_model", "navigation_gain", "NAVIGATION_MIN_S",
    # the library under it
    "diagnose", "Diagnosis", "Effect", "DiagnoseError", "crop", "ReferenceMotion", "Predictor", "predict_readings",
    "Candidate", "CANDIDATES", "PRIORITY", "jacobian_columns", "numeric_jacobian",
    "format_report", "to_json", "plot", "model_document", "model_toml", "DIAGNOSIS_SCHEMA", "PLOT_FILES",
    # the model vector
    "Param", "PARAMS", "NP", "theta_from_model", "CHANNELS", "UG", "DEG_PER_H",
    "A_BIAS", "A_SF", "A_MIS", "A_K2", "LEVER", "TAU_A", "TAU_R", "TILT", "G_BIAS", "G_SF", "G_MIS", "G_G",
    # limits
    "MIN_SAMPLES", "MAX_SAMPLES", "MAX_ROWS", "MIN_REFERENCE_ROWS", "EDGE_S", "EDGE_REFERENCE_PERIODS",
    "REFERENCE_GAP_FACTOR", "FOLDS", "FOLD_BLOCK_S", "KAPPA_BLOCK_S", "MAX_PASSES",
]

#: Records at least this long, with reference position, are also navigated before and after [s].
NAVIGATION_MIN_S = 600.0


def start_model(nominal: str | None = None, model: str | None = None):
    """The model vector the diagnosis starts from, and a phrase saying what it is.

    ``model``: a ``sizefx/effects/1`` TOML (sections it omits are off). Otherwise the
    ``nominal`` geometry (a preset or a ``sizefx/levers/1`` file; default high-precision)
    with no delays and no sensor errors.
    """
    if model is not None and nominal is not None:
        raise ConfigError("give --nominal or --model, not both: a model file carries its own lever arms")
    if model is not None:
        return theta_from_model(load_effects(model, base=IDEAL)), f"model {model}"
    from ..calibrate import nominal_levers

    name = nominal or "high-precision"
    th = np.zeros(NP)
    th[LEVER] = nominal_levers(name).arms_total.ravel()
    return th, f"nominal geometry {name}, no delays, no sensor errors"


def navigation_gain(tel: Telemetry, theta0: np.ndarray, theta: np.ndarray) -> dict | None:
    """Free-inertial horizontal error against ``/reference`` with the start and the extended model.

    Only for navigation-length records (:data:`NAVIGATION_MIN_S` or more, reference with
    position, no IMU gap). The models go to navigation in memory (:func:`model_document`).
    """
    if tel.reference is None or not tel.reference.has_position or tel.duration_s < NAVIGATION_MIN_S:
        return None
    if any(g.dataset.startswith("/imu") for g in tel.gaps):
        return None  # navigation cannot bridge an IMU gap; diagnose --segment K navigates one segment
    from ..navigate import NavConfig, navigate

    out = {"duration_s": float(tel.duration_s)}
    for name, th in (("before", theta0), ("after", theta)):
        model = load_effects(base=IDEAL, overrides=model_document(th))
        err = np.asarray(navigate(tel, NavConfig(model=model)).errors["horizontal_m"])
        out[name] = {"final_m": float(err[-1]), "max_m": float(np.max(err))}
    return out


def run(path, *, nominal: str | None = None, model: str | None = None, json_path=None, plots=None,
        model_out=None, bandwidth_hz: float | None = None, from_s: float | None = None, to_s: float | None = None,
        allow_gaps: bool = False, force: bool = False, navigation: bool = True, segment: int | None = None):
    """Entry point of ``sizefx diagnose``: returns ``(Diagnosis, report text, json document)``."""
    inputs = [path] + ([model] if model else [])
    if model_out is None:
        model_out = str(Path(path).with_suffix("")) + ".model.toml"
    outs = [o for o in (json_path, model_out) if o]
    if len({Path(o).resolve() for o in outs}) < len(outs):
        raise ConfigError(f"{json_path}: --json and --model-out name the same file; give two")
    for out in outs:
        check_output_path(out, inputs=inputs, force=force)
    if plots and any(Path(plots).resolve() == Path(p).resolve() for p in inputs):
        raise ConfigError(f"{plots}: --plots names an input file; give a folder")
    if segment is not None and (from_s is not None or to_s is not None):
        raise ConfigError(f"{path}: --segment {segment} and --from-s/--to-s both choose the span; give one "
                          "(sizefx inspect lists each segment's times)")
    theta0, start = start_model(nominal, model)
    tel = read_telemetry(path, allow_gaps=allow_gaps, segment=segment)
    require_reference(tel)
    d = diagnose(crop(tel, from_s, to_s), theta0, bandwidth_hz=bandwidth_hz, keep_series=bool(plots))
    write_toml(model_out, model_document(d.theta), header=model_header(str(path)), inputs=inputs, force=force)
    d.model_path = str(model_out)
    if navigation:
        d.navigation = navigation_gain(tel, theta0, d.theta)
    doc = to_json(d, start)
    if json_path:
        with atomic_output(json_path, force=force) as tmp:
            Path(tmp).write_text(json.dumps(doc, indent=2))
    if plots:
        doc["plots"] = plot(d, plots)
    return d, format_report(d, start), doc
