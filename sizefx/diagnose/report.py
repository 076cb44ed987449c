"""What diagnose writes and prints: the JSON report and the text report.

- :func:`to_json`: the ``sizefx/diagnosis/2`` document (``data-schemas/diagnosis-2.json``; version 1
  files still validate against ``diagnosis-1.json``, see :func:`check_diagnosis`);
- :func:`format_report`: the lines ``sizefx diagnose`` prints.

The extended model (:func:`model_document`, :func:`model_toml`) is :mod:`.extended`'s, the plots
(:func:`plot`) :mod:`.plots`'; both are imported from here as before.
"""

from __future__ import annotations

from .. import __version__
from ..constants import DEG_PER_H, MICRO_G
from ..errors import ConfigError
from ..io.documents import read_json
from ..io.schema import check_document, validate_input

# model_header too stays importable from here (sizefx.diagnose imports it so)
from .extended import model_document, model_header, model_toml  # noqa: F401
from .fit import Diagnosis
from .holdout import OutOfSample
from .plots import PLOT_FILES, plot
from .records import ModelChecks
from .selection import FAMILY_ALPHA
from .theta import CHANNELS, PARAMS

__all__ = [
    "DIAGNOSIS_SCHEMA",
    "DIAGNOSIS_SCHEMAS",
    "PLOT_FILES",
    "check_diagnosis",
    "format_report",
    "model_document",
    "model_toml",
    "plot",
    "read_diagnosis",
    "to_json",
]

DIAGNOSIS_SCHEMA = "sizefx/diagnosis/2"
#: Every report version a reader accepts (version 1: before warnings, rejected, unexplained and
#: consistency).
DIAGNOSIS_SCHEMAS = ("sizefx/diagnosis/1", DIAGNOSIS_SCHEMA)


# --------------------------------------------------------------------------- the reports


def _sigma_entry(d: Diagnosis, j: int) -> dict:
    return {
        "parameter": PARAMS[j].label,
        "effect": PARAMS[j].effect,
        "unit": PARAMS[j].unit,
        "sigma": d.sigma_theta[j] / PARAMS[j].per_unit,
        "sigma_white": d.sigma_white.get(j, 0.0) / PARAMS[j].per_unit,
    }


def to_json(d: Diagnosis, start: str, checks: ModelChecks | None = None) -> dict:
    """The ``sizefx/diagnosis/2`` document (checked against ``data-schemas/diagnosis-2.json``) of the fit
    ``d`` and, when the stage made them, ``checks``: the model file, the navigation, the other records."""
    checks = checks or ModelChecks()
    cons = dict(d.consistency)
    cons["standard_errors"] = [_sigma_entry(d, j) for j in sorted(d.sigma_theta)]
    doc = {
        "schema": DIAGNOSIS_SCHEMA,
        "sizefx_version": __version__,
        "record": d.path,
        "start_model": start,
        "warnings": [w.as_dict() for w in d.warnings],
        "unexplained": d.unexplained,
        "effects": [
            {
                "id": e.id,
                "channel": e.channel,
                "parameters": e.params,
                "sigma": e.sigma,
                "nominal": e.nominal,
                "explained_fraction": e.explained_fraction,
                "sentence": e.sentence,
                "not_revealed": e.hidden,
                **({"alternative": e.alternative.as_dict()} if e.alternative is not None else {}),
            }
            for e in d.effects
        ],
        "rejected": [r.as_dict() for r in d.rejected],
        "not_revealed": [u.as_dict() for u in d.unrevealed],
        "consistency": cons,
        "geometry": d.geometry,
        "grade": d.grade,
        "grade_reason": d.grade_reason,
        "bandwidth_hz": d.bandwidth_hz,
        "bandwidth_reason": d.bandwidth_reason,
        "residual_rms_before": d.rms_before,
        "residual_rms_after": d.rms_after,
        "residual_rms_full_band_before": d.rms_full_before,
        "residual_rms_full_band_after": d.rms_full_after,
        "units": {
            "gyro": "rad/s",
            "accel": "m/s^2",
            "lever_arm": "m",
            "tau_s": "s",
            "bias_mps2": "m/s^2",
            "bias_rad_s": "rad/s",
        },
        "model": checks.model_path,
        "samples": d.samples,
        "block_samples": d.block,
        "noise_sigma": dict(zip(CHANNELS, d.weights_sigma.tolist())),
        "kappa": dict(zip(CHANNELS, d.kappa.tolist())),
        "bias_walk": dict(zip(CHANNELS, d.bias_walk.tolist())),
        "bias_walk_slope": dict(zip(CHANNELS, d.bias_walk_slope.tolist())),
        "passes": d.passes,
        "selection_log": d.log,
        "navigation": checks.navigation,
        "wall_s": d.wall_s,
    }
    if d.out_of_sample is not None:
        windows = {} if checks.window_navigation is None else {"navigation": checks.window_navigation}
        doc["out_of_sample"] = {**d.out_of_sample.as_dict(), **windows}
    if checks.validated_on:
        doc["validated_on"] = [o.as_dict() for o in checks.validated_on]
    check_document(doc, DIAGNOSIS_SCHEMA)  # our writer against our contract: a bug if it fails
    return doc


def check_diagnosis(doc: dict, source: str = "report") -> dict:
    """Validate a diagnosis report of any version in :data:`DIAGNOSIS_SCHEMAS` against its schema."""
    version = doc.get("schema") if isinstance(doc, dict) else None
    if version not in DIAGNOSIS_SCHEMAS:
        raise ConfigError(
            f"{source}: schema {version!r} is not a diagnosis report (expected one of {', '.join(DIAGNOSIS_SCHEMAS)})"
        )
    validate_input(doc, version, source)
    return doc


def read_diagnosis(path) -> dict:
    """A ``sizefx diagnose --json`` file, version 1 or 2, validated."""
    doc = read_json(path, "diagnosis report (sizefx diagnose --json)")
    return check_diagnosis(doc, str(path))


def _rms_line(name, before, after):
    """One channel's residual RMS, start -> extended model, in deg/h or ug."""
    if name.startswith("gyro"):
        return f"  {name:8s} {before / DEG_PER_H:12.5g} -> {after / DEG_PER_H:12.5g} deg/h   ({_gain(before, after)})"
    return f"  {name:8s} {before / MICRO_G:12.5g} -> {after / MICRO_G:12.5g} ug      ({_gain(before, after)})"


def _gain(before, after):
    """How much lower the residual became, in words."""
    if before <= 0:
        return "no residual"
    change = 100.0 * (1.0 - after / before)
    if abs(change) < 0.05:
        return "unchanged"
    return f"{change:.1f} % lower" if change > 0 else f"{-change:.1f} % higher"


def _geometry_lines(g: dict) -> list[str]:
    """The arms split at the triad point (:mod:`.arms`), in mm."""

    def mm(v, s):
        return "(" + ", ".join(f"{1e3 * a:.3f}" for a in v) + ") +- (" + ", ".join(f"{1e3 * b:.3f}" for b in s) + ")"

    lines = [
        "arms split at the triad point C [mm, body axes]:",
        f"  C from the reference point {mm(g['triad_point_m'], g['triad_point_sigma_m'])}: the set-up's offset, "
        "as repeatable as the set-up",
    ]
    lines += [f"  d_{a} (C to accelerometer {a}) {mm(v, s)}" for a, v, s in zip("xyz", g["d_m"], g["d_sigma_m"])]
    lines[-1] += ": the IMU's own size effect"
    return lines


def format_report(d: Diagnosis, start: str, checks: ModelChecks | None = None) -> str:
    """The report ``sizefx diagnose`` prints. What may make the result untrustworthy comes first (the
    warnings), then what the model cannot explain; then the effects found, those rejected and what the
    record cannot reveal; the band, grade and error checks; the residual RMS per channel before and
    after, and, from ``checks`` (the stage's), the navigation gain, the other records and where the
    model went."""
    checks = checks or ModelChecks()
    how = (
        f", low-passed at {d.bandwidth_hz:g} Hz (every {d.block} samples)"
        if d.bandwidth_hz
        else f" in blocks of {d.block}"
        if d.block > 1
        else ""
    )
    lines = [f"sizefx diagnose {d.path}: {d.samples} samples{how}; start: {start}"]
    if d.warnings:
        lines.append(f"WARNINGS ({len(d.warnings)}):")
        lines += [f"  ! {w.kind}: {w.message}" for w in d.warnings]
    if d.unexplained:
        lines.append(f"UNEXPLAINED by the extended model ({len(d.unexplained)}):")
        lines += [f"  ? {u['channel']} {u['kind']}: {u['sentence']}" for u in d.unexplained]
    if d.effects:
        lines.append(
            f"found {len(d.effects)} effect(s) (forward selection: information criterion, robust Wald test at "
            f"a family-wise {100 * FAMILY_ALPHA:g} %, cross-validation; {d.passes} Gauss-Newton passes):"
        )
        for k, e in enumerate(d.effects, 1):
            where = f"{e.id}" + (f", {e.channel}" if e.channel else "")
            lines.append(
                f"  {k}. {e.sentence} [{where}; explains {100 * e.explained_fraction:.1f} % of the "
                "structure in its channels]"
            )
    elif changed := _changed_without_finding(d):
        lines.append(changed)
    else:
        white = d.white_sigma or {}
        loud = [c for c in CHANNELS if white and d.rms_after[c] > 1.5 * white[c]]
        channels_flagged = sorted({u["channel"] for u in d.unexplained})  # unexplained: dicts of structure.py
        if loud or channels_flagged or d.warnings:
            parts = [f"{c} ({d.rms_after[c] / white[c]:.1f} times its sample-to-sample noise)" for c in loud]
            parts += [f"{c} (structure above)" for c in channels_flagged if c not in loud]
            lines.append(
                "found nothing the data supports beyond the start model; but "
                + (
                    (
                        "the residual on " + ", ".join(parts) + " is more than noise: an effect outside the "
                        "candidates, or too little motion or data"
                    )
                    if parts
                    else "the warnings above say the record itself may be at fault"
                )
            )
        else:
            lines.append(
                "found nothing beyond the start model: the residual is consistent with sensor noise "
                "(no line, trend, step or correlation with the motion left in any channel)"
            )
    if d.rejected:
        lines.append("rejected (selected, but not a finding):")
        for r in d.rejected:
            where = r.id + (f" {r.channel}" if r.channel else "")
            lines.append(f"  - {where}: {r.reason}" + (f"; more likely {r.likely}" if r.likely else ""))
    if d.unrevealed:
        lines.append("not revealed by this record (kept at the start model; record more motion to see them):")
        for u in d.unrevealed:
            where = u.id + (f" {u.channel}" if u.channel else "")
            lines.append(f"  - {where} ({', '.join(u.parameters)}): {u.reason}")
            if u.separated_by:
                motion, rho = u.separated_by[0]
                lines.append(f"      would be told apart by {motion} (canonical correlation {rho:.2f} with it)")
    if d.geometry:
        lines += _geometry_lines(d.geometry)
    lines.append(f"band: {d.bandwidth_reason}; {d.grade_reason}")
    walking = _walk_words(d.bias_walk, d.bias_walk_slope)
    if walking:
        lines.append(f"bias walk measured beside the model (it widens the errors of slow parameters): {walking}")
    cons = d.consistency or {}
    flagged = [p for p in cons.get("parameters", []) if p["inflated"]]
    if cons.get("parameters"):
        worst = max(cons["parameters"], key=lambda p: p["chi2_dof"])
        lines.append(
            f"standard errors: the residual's spectrum at each regressor's time scales ({cons['block_s']:.2g} s "
            "blocks, split down to single rows), widened by the random effect of "
            f"{cons['parts']} parts of the record where they disagree beyond chance (largest chi2/dof {worst['chi2_dof']:.2f}, "
            f"{worst['effect']} {worst['parameter']})"
            + (f"; {len(flagged)} disagree beyond chance (see the warnings)" if flagged else "")
        )
    systematic = cons.get("systematic")
    if systematic:  # the parameter whose error the band's and the selection's part takes most of
        index = {(p.effect, p.label): j for j, p in enumerate(PARAMS)}
        share = {
            (q["effect"], q["parameter"]): q["sigma_selection"]
            * PARAMS[index[q["effect"], q["parameter"]]].per_unit
            / d.sigma_theta[index[q["effect"], q["parameter"]]]
            for q in systematic["parameters"]
        }
        # nothing estimated (a start model that already holds everything the record shows): no "most"
        most = ""
        if share:
            (effect, label), top = max(share.items(), key=lambda kv: kv[1])
            most = f" (most: {effect} {label}, {100 * top:.0f} % of its error)"
        lines.append(
            "standard errors include the band's and the selection's part, refitted at "
            + " and ".join(f"{b['bandwidth_hz']:.3g} Hz" for b in systematic["bands"])
            + most
        )
    band = f" (below {d.bandwidth_hz:g} Hz)" if d.bandwidth_hz else ""
    lines.append(f"residual RMS per channel{band}, start model -> extended model:")
    for name in CHANNELS:
        lines.append(_rms_line(name, d.rms_before[name], d.rms_after[name]))
    if d.bandwidth_hz:
        assert d.rms_full_before is not None and d.rms_full_after is not None  # diagnose() sets both
        lines.append("full band (the reference's differentiated noise included):")
        for name in CHANNELS:
            lines.append(_rms_line(name, d.rms_full_before[name], d.rms_full_after[name]))
    if checks.navigation:
        nav = checks.navigation
        lines.append(
            f"navigation over {nav['duration_s']:.0f} s (free inertial, against /reference): final "
            f"horizontal error {nav['before']['final_m']:.2f} m -> {nav['after']['final_m']:.2f} m, "
            f"maximum {nav['before']['max_m']:.2f} m -> {nav['after']['max_m']:.2f} m"
        )
    if d.out_of_sample is not None:
        lines += _out_of_sample_lines(d.out_of_sample, checks.window_navigation)
    for other in checks.validated_on:
        lines += _out_of_sample_lines(other)
    if checks.model_path:
        lines.append(f"extended model -> {checks.model_path} (sizefx navigate/compensate/diagnose --model accept it)")
    return "\n".join(lines)


def _changed_without_finding(d: Diagnosis) -> str:
    """With no effect named, what the extended model still changed: the channels whose residual it
    lowers on held-out data beyond chance, and the effects the motion cannot tell apart that could be
    the cause (empty when it changed nothing beyond chance)."""
    o = d.out_of_sample
    if d.effects or o is None or o.overfit:
        return ""
    lower = [c for c in CHANNELS if o.rms_after[c] < o.rms_before[c] * (1.0 - 1e-3)]
    if not lower:
        return ""
    could = sorted({u.key for u in d.unrevealed if "on this motion" in u.reason})
    return (
        "found no effect this record can name, but the extended model lowers the residual beyond chance (held out: "
        f"{_percent(o.gain)} of the weighted power, p = {o.p:.2g}) on "
        + ", ".join(f"{c} ({_gain(o.rms_before[c], o.rms_after[c])})" for c in lower)
        + (
            ": it could be "
            + (", ".join(could[:-1]) + " or " if len(could) > 1 else "")
            + could[-1]
            + ", which this motion cannot tell apart (see 'not revealed' for a motion that would)"
            if could
            else ""
        )
    )


def _percent(g: float) -> str:
    return f"{100 * g:.1f} %"


def _out_of_sample_lines(o: OutOfSample, windows: dict | None = None) -> list[str]:
    """The gain on data the model was not fitted to (:mod:`.holdout`): the record's own folds (with
    ``windows``, :attr:`ModelChecks.window_navigation`), or another record."""
    test = f"positive beyond chance: one-sided p = {o.p:.2g} over the blocks"
    if o.kind == "other record":
        lines = [
            f"validated on {o.record} (the extended model as fitted, in the same band): weighted residual "
            f"power {_percent(o.gain)} lower than with the start model ({test})"
            + ("; NOT a gain beyond chance: the model does not carry over to this record" if o.overfit else ""),
            "  residual RMS per channel, start model -> extended model:",
        ]
        lines += ["  " + _rms_line(c, o.rms_before[c], o.rms_after[c]) for c in CHANNELS]
        if o.navigation:
            nav = o.navigation
            lines.append(
                f"  navigation over {nav['duration_s']:.0f} s: final horizontal error "
                f"{nav['before']['final_m']:.2f} m -> {nav['after']['final_m']:.2f} m"
            )
        return lines
    assert o.rms_in_sample is not None and o.gain_in_sample is not None  # folds carry the in-sample figures
    tested = sum(p.determined for p in o.parts)
    untested = "" if tested == len(o.parts) else f"; {len(o.parts) - tested} not predictable from the others, left out"
    lines = [
        f"out of sample ({o.kind}, {len(o.parts)} folds{untested}; the selection kept, each fold's estimates "
        f"fitted without it): weighted residual power removed {_percent(o.gain_in_sample)} in sample, "
        f"{_percent(o.gain)} held out ({test})"
        + ("; NOT a gain beyond chance: the extended model is overfit" if o.overfit else ""),
        "  residual RMS per channel, start model -> in sample -> held out:",
    ]
    for c in CHANNELS:
        k, unit = (DEG_PER_H, "deg/h") if c.startswith("gyro") else (MICRO_G, "ug")
        lines.append(
            f"    {c:8s} {o.rms_before[c] / k:12.5g} -> {o.rms_in_sample[c] / k:12.5g} -> "
            f"{o.rms_after[c] / k:12.5g} {unit}"
        )
    for e in o.effects:
        lines.append(
            f"  {e.key}: removes {_percent(e.gain_in_sample)} in sample, {_percent(e.gain_held_out)} held out "
            f"(p = {e.p:.2g})" + ("" if e.generalises else ": not shown to generalise")
        )
    if windows and windows.get("windows"):
        lines.append(
            "  navigation over each fifth of the record, from the reference at its start (final horizontal error, "
            "start model -> fitted without it -> fitted to the whole record):"
        )
        for w in windows["windows"]:
            lines.append(
                f"    {w['t0_s']:.0f}-{w['t1_s']:.0f} s: {w['before']['final_m']:.2f} m -> "
                f"{w['after']['final_m']:.2f} m -> {w['in_sample']['final_m']:.2f} m"
            )
    return lines


def _walk_words(walk, slope) -> str:
    """The channels whose bias walks, in the units a data sheet gives: deg/h/sqrt(h) for a gyro's rate
    random walk, ug/sqrt(h) for an accelerometer's bias walk; "(flicker)" where the slow noise's
    spectrum falls as 1/f (:mod:`sizefx.diagnose.drift`)."""
    words = []
    for c, w, a in zip(CHANNELS, walk, slope):
        if w > 0:
            k, unit = (DEG_PER_H, "deg/h") if c.startswith("gyro") else (MICRO_G, "ug")
            kind = " (flicker)" if a < 2.0 else ""
            words.append(f"{c} {w / (k / 60.0):.3g} {unit}/sqrt(h){kind}")  # per sqrt(h): per 60 sqrt(s)
    return ", ".join(words)
