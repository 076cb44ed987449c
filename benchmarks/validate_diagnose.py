"""Validation protocol for sizefx diagnose: randomized truths, two disjoint seed ranges.

    python benchmarks/validate_diagnose.py --range dev|validation [--records 24] [--jobs 2]
        [--plot FILE.png] [--json out.json] [--record [LABEL]]

Each record is its own draw from the priors below (:func:`draw`): the motion, the geometry, a
random subset of effects with random sizes and signs, and the noise colour. ``sizefx diagnose``
then sees the record with the drawing's nominal geometry as its start model, as a user would, and
every parameter of a finding is judged against the truth: ``z = (estimate - truth) / sigma``.

**Two seed ranges, never mixed.** ``--range dev`` draws records from seeds 0, 1, 2, ...: tune the
error recipe, the selection and the thresholds on these. ``--range validation`` draws from
:data:`_validation.VALIDATION_FIRST_SEED` on: report these, never tune on them. Every change to the estimator
re-runs both (``--record dev`` and ``--record validation`` write
``benchmarks/results/validate_diagnose-dev.json`` and ``-validation.json``), and the docs quote
both.

Per effect kind (the effect model's sections): the records in which it was hidden, found, missed,
or reported "not revealed"; over the parameters diagnose reports, the z mean and RMS (with the
range chance alone gives the RMS of that many independent z-scores) and the coverage of the 68 % and
95 % intervals (``|z| <= 1`` and ``|z| <= 1.96``); and, for the plot, the
probability integral transform ``Phi(z)`` of each truth under the reported normal error, which is
uniform when the error bars are right (simulation-based calibration, Talts et al. 2018, with the
normal posterior's rank in closed form). A finding of an effect kind that was not hidden is a
false finding; the rate is per record.

The priors (SI inside, the effect model's file units in the draw):

- **Motion** (one of four, equally likely): a three-axis tumble of 120-180 s (amplitudes 60-150,
  30-80, 30-80 deg; frequencies 0.03-0.16 Hz) at 200 Hz; a single-axis sway (roll, pitch or
  heading; 0.5, 1 or 2 Hz; two rate amplitudes of 5-30 deg/s; 150 s) at 200 Hz; the paper's
  three-axis turntable plan shortened to 40 s per axis (peak rate 10-30 deg/s) at 200 Hz; a short
  helicopter flight (480-600 s, rotor vibration at 8 Hz and its harmonics) at 400 Hz (at 100 Hz,
  the reference would hold the 32 Hz harmonic in three samples a period: no recorder of a flight
  trial logs its reference so).
- **Geometry**: the high-precision design's arms (the start model) moved by a rotation-centre
  offset ``r0`` of 0-50 mm in a random direction; with probability 1/2, each accelerometer's arm
  also differs from the drawing by 0.5-5 mm per component.
- **Effects**: each other effect kind hidden with probability 0.3, every component with a
  log-uniform size and a random sign (:data:`SIZES`, navigation grade).
- **Noise**: white noise always (accelerometers 2-10 ug/sqrt(Hz), gyros 0.0002-0.002
  deg/sqrt(h)); each of these with probability 1/2: a bias random walk (2-30 ug/sqrt(h),
  0.0005-0.005 deg/h/sqrt(h)), a first-order Gauss-Markov accelerometer noise (2-10 ug/sqrt(Hz),
  0.05-2 s), flicker (1/f) noise on every channel, and one or two vibration lines (15-45 Hz).

The truth is the drawn effect model's deterministic terms (:func:`sizefx.diagnose.theta_from_model`);
the noise, the walk included, is what the error bars must cover.
"""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from sizefx import diagnose as D
from sizefx import scenarios as S
from sizefx.diagnose.candidates import CANDIDATES
from sizefx.effects import IDEAL, load_effects
from sizefx.geometry import preset_arms_m
from sizefx.simulate import simulate_in_memory

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (siblings of this script)
from _validation import RANGES, plot_pit, run_jobs, seeds

#: Log-uniform size ranges (low, high) of each hidden effect's components, in the effect model's
#: file units; each component gets its own size and sign. Navigation grade, wide enough that some
#: draws sit below what a short record reveals (a miss there is not a failure; its count is shown).
SIZES = {
    "accel_bias": ("bias_ug", (10.0, 200.0), 3),
    "accel_scale_factor": ("ppm", (10.0, 300.0), 3),
    "accel_misalignment": ("arcsec", (2.0, 30.0), "offdiag"),
    "accel_quadratic": ("ug_per_g2", (5.0, 50.0), 3),
    "accel_delay": ("tau_s", (1e-4, 1e-3), 1),
    "reference_delay": ("tau_s", (5e-4, 5e-3), 1),
    "level_tilt": (("north_arcsec", "east_arcsec"), (2.0, 20.0), 2),
    "gyro_bias": ("deg_per_h", (0.005, 0.1), 3),
    "gyro_scale_factor": ("ppm", (2.0, 30.0), 3),
    "gyro_misalignment": ("arcsec", (1.0, 10.0), "offdiag"),
    "gyro_g_sensitivity": ("deg_per_h_per_g", (0.05, 0.5), "matrix"),
    "reference_mount": ("arcsec", (10.0, 300.0), 3),
}
#: The probability that each effect kind of :data:`SIZES` is hidden in a record.
P_EFFECT = 0.3
MOTIONS = ("tumble", "sway", "turntable", "flight")
NOISES = ("bias_walk", "gauss_markov", "flicker", "vibration")
#: The nominal design diagnose starts from, as a user with the drawing would.
NOMINAL_OVERRIDES = {"lever_arm": {"enabled": True, "preset": "high-precision"}}


def _loguniform(rng, low, high, size=None):
    return np.exp(rng.uniform(np.log(low), np.log(high), size))


def _signed(rng, low, high, size):
    return _loguniform(rng, low, high, size) * rng.choice((-1.0, 1.0), size)


def draw_motion(rng, motions=MOTIONS) -> tuple[str, object, float]:
    """``(kind, trajectory, rate_hz)`` of one record, its kind drawn from ``motions``."""
    kind = motions[rng.integers(len(motions))]
    if kind == "tumble":
        traj = S.tumble(
            float(rng.uniform(120.0, 180.0)),
            amplitudes_deg=(rng.uniform(60, 150), rng.uniform(30, 80), rng.uniform(30, 80)),
            freqs_hz=(rng.uniform(0.03, 0.08), rng.uniform(0.06, 0.12), rng.uniform(0.09, 0.16)),
        )
        return kind, traj, 200.0
    if kind == "sway":
        plan = S.SwayPlan(
            axis=("roll", "pitch", "heading")[rng.integers(3)],
            amplitudes_dps=tuple(float(a) for a in rng.uniform(5.0, 30.0, 2)),
            frequency_hz=float(rng.choice((0.5, 1.0, 2.0))),
            static_s=30.0,
            segment_s=60.0,
        )
        return kind, S.sway(plan)[0], 200.0
    if kind == "turntable":
        plan = S.TurntablePlan(
            static_s=20.0,
            seconds_per_axis=40.0,
            cycles=2,
            peak_rate_dps=float(rng.uniform(10, 30)),
            reposition_s=10.0,
            settle_s=5.0,
        )
        return kind, S.turntable(plan)[0], 200.0
    plan = S.FlightPlan(
        duration_s=float(rng.uniform(480.0, 600.0)),
        align_s=60.0,
        speed_mps=20.0,
        turn_rate_dps=10.0,
        altitude_m=100.0,
        weave_deg=0.0,
        climb_step_m=0.0,
    )
    return kind, S.flight(plan)[0], 400.0  # the rotor's 32 Hz harmonic needs a reference that resolves it


def draw_effects(rng) -> tuple[dict, dict]:
    """``(overrides, noise)``: the effect model's sections of one record and its extra noise kinds."""
    r0 = rng.normal(size=3)
    r0 *= rng.uniform(0.0, 0.05) / np.linalg.norm(r0)
    lever = {"enabled": True, "preset": "high-precision", "r0_m": r0.tolist()}
    if rng.random() < 0.5:
        arms = preset_arms_m("high-precision") + _signed(rng, 5e-4, 5e-3, (3, 3))  # moved per component
        lever |= {f"d_{a}_m": arms[i].tolist() for i, a in enumerate("xyz")}
    overrides = {"lever_arm": lever}
    for kind, (key, (low, high), shape) in SIZES.items():
        if rng.random() >= P_EFFECT:
            continue
        if shape == "offdiag":
            m = _signed(rng, low, high, (3, 3))
            np.fill_diagonal(m, 0.0)
            values = {key: m.tolist()}
        elif shape == "matrix":
            values = {key: _signed(rng, low, high, (3, 3)).tolist()}
        elif shape == 1:
            values = {key: float(_loguniform(rng, low, high))}
        elif shape == 2:
            values = dict(zip(key, _signed(rng, low, high, 2).tolist()))
        else:
            values = {key: _signed(rng, low, high, shape).tolist()}
        overrides[kind] = {"enabled": True, **values}
    noise = {name: bool(rng.random() < 0.5) for name in NOISES}
    overrides["accel_noise"] = {
        "enabled": True,
        "density_ug_per_sqrt_hz": float(_loguniform(rng, 2.0, 10.0)),
        "bias_rw_ug_per_sqrt_h": float(_loguniform(rng, 2.0, 30.0)) if noise["bias_walk"] else 0.0,
        "markov_density_ug_per_sqrt_hz": float(_loguniform(rng, 2.0, 10.0)) if noise["gauss_markov"] else 0.0,
        "markov_correlation_s": float(_loguniform(rng, 0.05, 2.0)),
    }
    overrides["gyro_noise"] = {
        "enabled": True,
        "arw_deg_per_sqrt_h": float(_loguniform(rng, 2e-4, 2e-3)),
        "rrw_deg_per_h_per_sqrt_h": float(_loguniform(rng, 5e-4, 5e-3)) if noise["bias_walk"] else 0.0,
    }
    return overrides, noise


def add_colour(tel, rng, noise: dict, overrides: dict):
    """Flicker and vibration lines on top of the simulated noise, sized against its white part."""
    n, rate = tel.time_s.size, 1.0 / float(np.median(np.diff(tel.time_s)))
    white_a = overrides["accel_noise"]["density_ug_per_sqrt_hz"] * 9.80665e-6 * np.sqrt(rate / 2)
    white_g = overrides["gyro_noise"]["arw_deg_per_sqrt_h"] * np.pi / 180 / 60 * np.sqrt(rate / 2)
    if noise["flicker"]:  # 1/f: octave-spaced first-order low-passes, 0.02 Hz up, equal power each
        flicker = np.zeros((n, 6))
        for k in range(8):
            a = np.exp(-2 * np.pi * 0.02 * 2**k / rate)
            flicker += lfilter([1.0], [1.0, -a], rng.normal(size=(n, 6)) * np.sqrt(1 - a * a), axis=0)
        flicker /= np.sqrt(8.0)
        tel.gyro_rad_s = tel.gyro_rad_s + 0.5 * white_g * flicker[:, :3]
        tel.accel_mps2 = tel.accel_mps2 + 0.5 * white_a * flicker[:, 3:]
    if noise["vibration"]:
        for _ in range(rng.integers(1, 3)):
            f, phase = rng.uniform(15.0, 45.0), rng.uniform(0, 2 * np.pi, 6)
            line = np.sin(2 * np.pi * f * tel.time_s[:, None] + phase)
            tel.gyro_rad_s = tel.gyro_rad_s + 2.0 * white_g * rng.uniform(0.2, 1.0, 3) * line[:, :3]
            tel.accel_mps2 = tel.accel_mps2 + 2.0 * white_a * rng.uniform(0.2, 1.0, 3) * line[:, 3:]
    return tel


def _effect_present(kind: str, truth: np.ndarray, nominal: np.ndarray) -> bool:
    idx = [j for j, p in enumerate(D.PARAMS) if p.effect == kind]
    return bool(np.any(truth[idx] != nominal[idx]))


def finding_parameters(d) -> list[int]:
    """The indices into theta of what diagnose reports as findings: each found effect's parameters
    but those it says the record does not reveal. A parameter the report lists as not revealed
    (the motion does not excite it, or it is indistinguishable from another candidate and the
    extended model carries their sum under one name) is no estimate of its own truth; its count
    is shown (``not_revealed``), its value is not judged."""
    cands = {(c.id, c.channel): c for c in CANDIDATES}
    out = []
    for e in d.effects:
        for j in cands[(e.id, e.channel)].idx:
            if D.PARAMS[j].label not in e.hidden and d.sigma_theta.get(j, 0) > 0:
                out.append(j)
    return sorted(set(out))


def judge(seed: int, motions=MOTIONS) -> dict:
    """Draw, simulate and diagnose record ``seed``; what diagnose found against the truth."""
    rng = np.random.default_rng(seed)
    motion, traj, rate_hz = draw_motion(rng, motions)
    overrides, noise = draw_effects(rng)
    fx = load_effects(base=IDEAL, overrides=overrides)
    tel = simulate_in_memory(traj, fx, rate_hz=rate_hz, form="rates", seed=int(rng.integers(2**31)))
    tel = add_colour(tel, rng, noise, overrides)
    truth = D.theta_from_model(fx)
    nominal = D.theta_from_model(load_effects(base=IDEAL, overrides=NOMINAL_OVERRIDES))
    d = D.diagnose(tel, nominal, keep_series=False)
    hidden = sorted({p.effect for p in D.PARAMS if _effect_present(p.effect, truth, nominal)})
    found = sorted({e.id for e in d.effects})
    unrevealed = sorted({u.id for u in d.unrevealed})
    z = [
        {
            "effect": D.PARAMS[j].effect,
            "label": D.PARAMS[j].label,
            "z": float((d.theta[j] - truth[j]) / d.sigma_theta[j]),
        }
        for j in finding_parameters(d)
    ]
    cv = d.out_of_sample
    held_out = [
        {
            "effect": g.key,
            "true": g.key.split(":")[0] in hidden,
            "generalises": g.generalises,
            "gain_in_sample": g.gain_in_sample,
            "gain_held_out": g.gain_held_out,
        }
        for g in (cv.effects if cv is not None else ())
    ]
    return {
        "seed": seed,
        "motion": motion,
        "noise": sorted(k for k, v in noise.items() if v),
        "hidden": hidden,
        "found": found,
        "unrevealed": unrevealed,
        "false": sorted(set(found) - set(hidden)),
        "missed": sorted(set(hidden) - set(found) - set(unrevealed)),
        "z": z,
        "held_out": held_out,
        "overfit": bool(cv is not None and cv.overfit),
        "resolved": [
            {"effect": e.id, "true": e.id in hidden, "alternative": e.alternative.key}
            for e in d.effects
            if e.alternative is not None
        ],
    }


def summarise(rows: list[dict]) -> dict:
    kinds = sorted({p.effect for p in D.PARAMS})
    by_effect = {}
    for kind in kinds:
        z = np.array([q["z"] for r in rows for q in r["z"] if q["effect"] == kind])
        entry = {
            "hidden_in": sum(kind in r["hidden"] for r in rows),
            "found": sum(kind in r["hidden"] and kind in r["found"] for r in rows),
            "not_revealed": sum(kind in r["hidden"] and kind in r["unrevealed"] for r in rows),
            "missed": sum(kind in r["missed"] for r in rows),
            "false_findings": sum(kind in r["false"] for r in rows),
            "parameters": int(z.size),
        }
        if z.size:
            entry |= {
                "mean_z": float(z.mean()),
                "rms_z": float(np.sqrt(np.mean(z**2))),
                "rms_z_chance_95": _rms_chance(z.size),
                "max_abs_z": float(np.abs(z).max()),
                "coverage_68": float(np.mean(np.abs(z) <= 1.0)),
                "coverage_95": float(np.mean(np.abs(z) <= 1.959964)),
            }
        if entry["hidden_in"] or entry["false_findings"] or z.size:
            by_effect[kind] = entry
    z_all = np.array([q["z"] for r in rows for q in r["z"]])
    by_motion = {}
    for motion in MOTIONS:
        mine = [r for r in rows if r["motion"] == motion]
        zm = np.array([q["z"] for r in mine for q in r["z"]])
        if mine:
            by_motion[motion] = {
                "records": len(mine),
                "parameters": int(zm.size),
                "rms_z": float(np.sqrt(np.mean(zm**2))) if zm.size else None,
                "coverage_95": float(np.mean(np.abs(zm) <= 1.959964)) if zm.size else None,
                "records_with_false_findings": sum(bool(r["false"]) for r in mine),
            }
    return {
        "records": len(rows),
        "seeds": [rows[0]["seed"], rows[-1]["seed"]] if rows else [],
        "by_effect": by_effect,
        "by_motion": by_motion,
        "all_parameters": {
            "parameters": int(z_all.size),
            "mean_z": float(z_all.mean()),
            "rms_z": float(np.sqrt(np.mean(z_all**2))),
            "coverage_68": float(np.mean(np.abs(z_all) <= 1.0)),
            "coverage_95": float(np.mean(np.abs(z_all) <= 1.959964)),
        }
        if z_all.size
        else {},
        "records_with_false_findings": sum(bool(r["false"]) for r in rows),
        "false_findings_per_record": sum(len(r["false"]) for r in rows) / max(len(rows), 1),
        # the cross-validated gain (sizefx.diagnose.holdout): how often it flags a finding as not
        # generalising, among true findings and among false ones, and records flagged overfit
        "held_out": {
            "true_findings": sum(h["true"] for r in rows for h in r.get("held_out", [])),
            "true_flagged": sum(h["true"] and not h["generalises"] for r in rows for h in r.get("held_out", [])),
            "false_findings": sum(not h["true"] for r in rows for h in r.get("held_out", [])),
            "false_flagged": sum(not h["true"] and not h["generalises"] for r in rows for h in r.get("held_out", [])),
            "records_overfit": sum(r.get("overfit", False) for r in rows),
        },
        # findings the grade resolved from an alias (sizefx.diagnose.aliases): how many were the truth
        "resolved_aliases": {
            "findings": sum(len(r.get("resolved", [])) for r in rows),
            "true": sum(q["true"] for r in rows for q in r.get("resolved", [])),
        },
        "targets": {
            "rms_z": [0.85, 1.2],
            "abs_mean_z": 0.2,
            "coverage_95": [0.93, 0.97],
            "false_findings_per_record": 0.01,
        },
        "rows": rows,
    }


def _rms_chance(n: int) -> list:
    """The central 95 % range of the RMS of ``n`` independent z-scores when the errors are right
    (``sqrt(chi2_n / n)``): how far a kind's z RMS strays from 1 by chance alone. A record's
    parameters are not independent (nine arms share one fit), so the true range is wider."""
    from scipy.stats import chi2

    return [float(np.sqrt(chi2.ppf(q, n) / n)) for q in (0.025, 0.975)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--range", choices=RANGES, required=True, help="the seed range (see above)")
    ap.add_argument("--records", type=int, default=24, help="records drawn from the range's first seeds")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument(
        "--motions",
        default=",".join(MOTIONS),
        help="draw the motion from these only (a diagnostic subset; the protocol's figures use all four)",
    )
    ap.add_argument("--plot", type=Path, help="write the simulation-based-calibration histograms here (PNG)")
    add_output_options(ap)
    args = ap.parse_args(argv)
    motions = tuple(args.motions.split(","))
    if set(motions) - set(MOTIONS) or not motions:
        ap.error(f"--motions {args.motions!r}: use some of {', '.join(MOTIONS)}")
    rows = run_jobs(functools.partial(judge, motions=motions), seeds(args.range, args.records), args.jobs)
    for r in rows:
        zs = np.array([q["z"] for q in r["z"]])
        print(
            f"  {r['seed']:>8} {r['motion']:9s} noise {','.join(r['noise']) or 'white':38s} hidden {len(r['hidden']):2d} "
            f"found {len(r['found']):2d} false {r['false'] or '-'} missed {r['missed'] or '-'} "
            f"max|z| {np.abs(zs).max() if zs.size else 0:.1f}",
            flush=True,
        )
    summary = summarise(rows)
    print(
        f"{'effect':20s} {'hidden':>6s} {'found':>5s} {'n.rev':>5s} {'miss':>4s} {'false':>5s} {'n':>4s} "
        f"{'mean z':>7s} {'z RMS':>6s} {'chance':>9s} {'max|z|':>7s} {'68 %':>5s} {'95 %':>5s}"
    )
    for kind, e in summary["by_effect"].items():
        stats = (
            f"{e['mean_z']:7.2f} {e['rms_z']:6.2f} {e['rms_z_chance_95'][0]:4.2f}-{e['rms_z_chance_95'][1]:4.2f} "
            f"{e['max_abs_z']:7.1f} {e['coverage_68']:5.2f} {e['coverage_95']:5.2f}"
            if e["parameters"]
            else ""
        )
        print(
            f"{kind:20s} {e['hidden_in']:6d} {e['found']:5d} {e['not_revealed']:5d} {e['missed']:4d} "
            f"{e['false_findings']:5d} {e['parameters']:4d} {stats}"
        )
    a = summary["all_parameters"]
    if a:
        print(
            f"all parameters: n {a['parameters']}, mean z {a['mean_z']:.2f}, z RMS {a['rms_z']:.2f}, "
            f"68 % {a['coverage_68']:.2f}, 95 % {a['coverage_95']:.2f}; records with a false finding "
            f"{summary['records_with_false_findings']} of {summary['records']}"
        )
    for motion, m in summary["by_motion"].items():
        print(
            f"  {motion:9s}: {m['records']} records, {m['parameters']} parameters, z RMS {m['rms_z'] or 0:.2f}, "
            f"95 % {m['coverage_95'] or 0:.2f}, false findings in {m['records_with_false_findings']}"
        )
    h, res = summary["held_out"], summary["resolved_aliases"]
    print(
        f"held out: {h['true_flagged']} of {h['true_findings']} true findings and {h['false_flagged']} of "
        f"{h['false_findings']} false ones flagged as not generalising; {h['records_overfit']} records overfit; "
        f"{res['findings']} findings resolved from an alias by the grade, {res['true']} of them true"
    )
    code = emit(summary, args, __file__, argv, threads=args.jobs, show=False)
    if args.plot:
        by_kind = {k: [q["z"] for r in rows for q in r["z"] if q["effect"] == k] for k in summary["by_effect"]}
        by_kind = {k: z for k, z in by_kind.items() if len(z) >= 5}
        plot_pit(by_kind, args.plot, f"diagnose, {args.range} range, {len(rows)} records")
    return code


if __name__ == "__main__":
    sys.exit(main())
