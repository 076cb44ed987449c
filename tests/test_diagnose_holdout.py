"""The gain out of sample (:mod:`sizefx.diagnose.holdout`): blocked folds in time and other records.

A model fitted to noise lowers the residual in sample by construction; the held-out checks must
say it does not predict data it was not fitted to, and must not say so of a real effect."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
from click.testing import CliRunner
from test_diagnose import HIDDEN, NOMINAL, record

from sizefx import diagnose as D
from sizefx.diagnose.candidates import columns_between
from sizefx.diagnose.holdout import HOLDOUT_FOLDS, OVERFIT_ALPHA, cross_validate, validate_on
from sizefx.diagnose.normal import Rows, normal_equations, solve
from sizefx.diagnose.predictor import Predictor
from sizefx.diagnose.residual import residual_under
from sizefx_cli.main import main


def _fit(tel, free):
    """``free`` (indices into theta) fitted by hand to ``tel`` from the nominal model, whatever the
    data support: the cross-validation's input as :func:`sizefx.diagnose.diagnose` would give it."""
    pred = Predictor(tel)
    rows_of = Rows(pred.t, pred.mask, pred.dt)
    before = residual_under(pred, rows_of, NOMINAL).rows
    sigma = np.sqrt(np.mean(np.diff(before, axis=0) ** 2, axis=0) / 2.0)
    weights = 1.0 / sigma**2
    theta = NOMINAL.copy()
    for _ in range(2):  # Gauss-Newton: the arms are linear, the scale factors nearly so
        cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)
        nrm = normal_equations(rows_of, residual_under(pred, rows_of, theta).rows, cols, weights)
        x, _, _ = solve(*nrm.total(), free, NOMINAL - theta)
        theta[free] += x
    final = residual_under(pred, rows_of, theta).rows
    cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)
    nrm = normal_equations(rows_of, final, cols, weights)
    return pred, rows_of, nrm, theta, weights, before, final


def test_a_real_effect_generalises_and_a_spurious_one_does_not():
    """Accelerometer y's arm is hidden, the accelerometer scale factors are not: fitted together, the
    arm predicts every held-out fold (its held-out gain close to its in-sample one), the scale
    factors, fitted to the noise, lower the residual in sample and predict nothing held out."""
    tel, _ = record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=60.0, seed=4)
    arm, sf = list(D.LEVER[3:6]), list(D.A_SF)
    free = np.array(sorted(arm + sf))
    pred, rows_of, nrm, theta, weights, before, final = _fit(tel, free)
    cv = cross_validate(pred, rows_of, nrm, NOMINAL, theta, free, {"arm": arm, "sf": sf}, weights, before, final)
    assert cv is not None and len(cv.parts) == HOLDOUT_FOLDS and all(p.determined for p in cv.parts)
    gains = {e.key: e for e in cv.effects}
    assert gains["arm"].generalises and gains["arm"].p < 1e-6
    assert gains["arm"].gain_held_out == pytest.approx(gains["arm"].gain_in_sample, rel=0.05)
    assert gains["sf"].gain_in_sample > 0.0  # any parameter freed lowers the residual in sample
    assert gains["sf"].gain_held_out < gains["sf"].gain_in_sample
    assert not gains["sf"].generalises and gains["sf"].p > OVERFIT_ALPHA
    assert not cv.overfit  # the model as a whole predicts: the arm carries it
    assert cv.gain == pytest.approx(cv.gain_in_sample, abs=0.01)
    for part in cv.parts:  # each fold's model is fitted without it: its own, none the whole record's
        assert part.gain > 0.5
        assert part.theta is not None and not np.array_equal(part.theta, theta)


def test_a_model_fitted_to_noise_alone_is_flagged_overfit():
    tel, _ = record({}, duration_s=60.0, seed=6)
    free = np.array(sorted(list(D.A_SF) + list(D.A_BIAS)))
    pred, rows_of, nrm, theta, weights, before, final = _fit(tel, free)
    cv = cross_validate(pred, rows_of, nrm, NOMINAL, theta, free, {"sf": list(D.A_SF)}, weights, before, final)
    assert cv is not None
    assert cv.gain_in_sample > 0.0 and cv.gain < cv.gain_in_sample
    assert cv.overfit and cv.p > OVERFIT_ALPHA
    doc = cv.as_dict()
    json.dumps(doc, allow_nan=False)  # JSON without inf or nan
    assert doc["overfit"] is True and len(doc["parts"]) == HOLDOUT_FOLDS


def test_nothing_estimated_is_not_cross_validated():
    tel, _ = record({}, duration_s=30.0, seed=7)
    d = D.diagnose(tel, NOMINAL, grade="navigation")
    assert not d.effects and d.out_of_sample is None


def test_a_finding_that_does_not_predict_held_out_folds_is_no_finding(monkeypatch):
    """Significant in sample is not enough: a finding whose held-out gain is not positive beyond
    chance goes to not_revealed with both gains in its reason, and the extended model still carries
    it. Here the held-out test is made to refuse the arm a real record reveals (a false finding that
    passed the in-sample test would be refused the same way)."""
    import dataclasses

    import sizefx.diagnose.fit as fit

    real = fit.cross_validate

    def refuses_the_arm(*args, **kwargs):
        cv = real(*args, **kwargs)
        effects = [
            dataclasses.replace(e, generalises=False, p=0.3) if e.key == "lever_arm:accel_y" else e for e in cv.effects
        ]
        return dataclasses.replace(cv, effects=effects)

    tel, _ = record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=40.0, seed=8)
    d = D.diagnose(tel, NOMINAL, grade="navigation")
    assert ("lever_arm", "accel_y") in {(e.id, e.channel) for e in d.effects}
    monkeypatch.setattr(fit, "cross_validate", refuses_the_arm)
    refused = D.diagnose(tel, NOMINAL, grade="navigation")
    assert ("lever_arm", "accel_y") not in {(e.id, e.channel) for e in refused.effects}
    why = next(u.reason for u in refused.unrevealed if (u.id, u.channel) == ("lever_arm", "accel_y"))
    assert "held-out folds, not beyond chance (p = 0.3)" in why and "extended model carries it" in why
    assert refused.theta[D.LEVER[3:6]] == pytest.approx(d.theta[D.LEVER[3:6]])


def test_validate_on_another_record_gains_where_the_effect_is_and_loses_where_it_is_not():
    """The arm of record A carries over to record B of the same IMU (another noise, another tumble),
    and is refused on record C, whose accelerometer y sits where the nominal geometry says."""
    tel_a, _ = record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=40.0, seed=8)
    d = D.diagnose(tel_a, NOMINAL, grade="navigation")
    assert ("lever_arm", "accel_y") in {(e.id, e.channel) for e in d.effects}
    assert d.out_of_sample is not None and not d.out_of_sample.overfit
    weights = 1.0 / (d.weights_sigma**2 * d.kappa)
    tel_b, _ = record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=40.0, seed=9, axes="xzy")
    same = validate_on(tel_b, NOMINAL, d.theta, d.bandwidth_hz, weights)
    assert not same.overfit and same.gain > 0.5 and same.p < 1e-6
    assert same.rms_after["accel_y"] < 0.5 * same.rms_before["accel_y"]
    tel_c, _ = record({}, duration_s=40.0, seed=10)
    other = validate_on(tel_c, NOMINAL, d.theta, d.bandwidth_hz, weights)
    assert other.overfit and other.gain < 0.0
    assert other.rms_after["accel_y"] > other.rms_before["accel_y"]


def test_cli_validate_on_reports_each_record_and_refuses_a_missing_one(tmp_path):
    from sizefx.io.writer import write_telemetry

    paths = []
    for seed in (11, 12):
        tel, _ = record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=30.0, seed=seed)
        paths.append(tmp_path / f"r{seed}.h5")
        write_telemetry(paths[-1], tel)
    out = tmp_path / "d.json"
    args = ["diagnose", str(paths[0]), "--nominal", "high-precision", "--grade", "navigation", "--json", str(out)]
    result = CliRunner().invoke(main, [*args, "--validate-on", str(paths[1])])
    assert result.exit_code == 0, result.output
    assert f"validated on {paths[1]}" in result.output
    assert "out of sample (blocked folds in time" in result.output
    doc = json.loads(out.read_text())
    D.check_diagnosis(doc)
    assert doc["validated_on"][0]["record"] == str(paths[1]) and not doc["validated_on"][0]["overfit"]
    assert doc["out_of_sample"]["kind"] == "blocked folds in time"
    missing = tmp_path / "absent.h5"
    result = CliRunner().invoke(main, [*args, "--force", "--validate-on", str(missing)])
    assert result.exit_code == 2
    assert str(missing) in result.output and "Traceback" not in result.output


def test_cli_validate_on_a_record_too_slow_for_the_band_is_refused_in_one_line(tmp_path):
    from sizefx.io.writer import write_telemetry

    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    write_telemetry(a, record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=30.0, seed=13)[0])
    write_telemetry(b, record({"lever_arm": HIDDEN["lever_arm"]}, duration_s=30.0, seed=14, rate_hz=50.0)[0])
    model = tmp_path / "a.model.toml"
    result = CliRunner().invoke(
        main,
        ["diagnose", str(a), "--grade", "navigation", "--bandwidth-hz", "30", "--validate-on", str(b)],
    )
    assert result.exit_code == 2, result.output
    assert str(b) in result.output and "--validate-on" in result.output and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not model.exists()  # refused before anything is written
