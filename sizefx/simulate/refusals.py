"""What refuses a simulated record before it is published, naming the effects that cause it: every
chunk against the telemetry contract's sample limits (:func:`_refuse_invalid`), and the record as
``sizefx inspect`` judges it by default (:func:`_refuse_implausible`), on rows copied from the chunks
as they pass (:class:`_Sample`)."""

from __future__ import annotations

import numpy as np

from ..effects import EffectModel
from ..errors import ConfigError
from ..io.telemetry import Reference, Site, Telemetry

# nothing public: what simulate_to_file (:mod:`.record`) calls
__all__: list[str] = []


def _differs(value, default) -> bool:
    """An effect key's value (as given: a number, a list, an array, a text) is not its default."""
    if isinstance(value, str) or isinstance(default, str) or value is None or default is None:
        return value != default
    return not np.array_equal(np.asarray(value, dtype=float), np.asarray(default, dtype=float))


def _changed_effects(effects: EffectModel, sensor: str) -> list[str]:
    """The effects on ``sensor`` ("accel" or "gyro"; the quantisation acts on both, the reference's
    effects count for the gyros, which are checked against the reference) that are on and differ from
    their defaults: ``section.key`` for each key set away from its default, ``section`` for one only
    switched on. What ``--set``, ``--effects``, ``--offset-mm`` and ``--geometry`` changed."""
    from ..effects import EFFECTS_SCHEMA
    from ..io.schema import load_schema
    from ..sensor_model import EFFECTS

    sensors = {"accel": ("accel", "both"), "gyro": ("gyro", "both", "reference")}[sensor]
    sections = load_schema(EFFECTS_SCHEMA)["sections"]
    named = []
    for effect in EFFECTS:
        if effect.sensor not in sensors or not effects.enabled(effect.name):
            continue
        raw = effects.raw.get(effect.name, {})
        keys = [
            k
            for k, rule in sections[effect.name]["keys"].items()
            if k != "enabled" and k in raw and _differs(raw[k], rule["default"])
        ]
        if keys:
            named += [f"{effect.name}.{k}" for k in keys]
        elif not sections[effect.name]["keys"]["enabled"]["default"]:
            named.append(effect.name)
    return named


def _blame(scenario: str, effects: EffectModel, sensor: str) -> str:
    """Which of the user's choices make the ``sensor`` readings what they are, for a refusal."""
    changed = _changed_effects(effects, sensor)
    if not changed:
        return f"the {scenario} motion's options with the default {sensor} effects (effects: {effects.source})"
    return f"the {scenario} motion with {', '.join(changed)} (effects: {effects.source})"


def _refuse_invalid(out, scenario: str, effects: EffectModel, form: str, t, gyro, accel):
    """The last guard of the contract on each chunk: every sample finite (no NaN or inf in /imu) and
    within the schema's ``sample_limits``, which the reader refuses with or without
    ``--no-units-check``. Every in-range effect value is meant to give finite readings
    (tests/test_consistent_inputs.py sweeps them); one that does not, or a motion and effects that
    reach beyond the limits, are refused here, naming the effects, and the atomic writer leaves
    nothing behind."""
    from ..io.contract import invalid_rows
    from ..io.schema import TELEMETRY_SCHEMA, load_schema

    schema = load_schema(TELEMETRY_SCHEMA)
    for name, dataset, values in zip(("gyro", "accel"), schema["forms"][form]["datasets"], (gyro, accel)):
        bad = invalid_rows(schema, dataset, values)
        if not np.any(bad):
            continue
        k, column = (int(v) for v in np.argwhere(bad)[0])
        if not np.isfinite(values[k, column]):
            raise ConfigError(
                f"{out}: the effects ({effects.source}) make {name} readings that are not finite at "
                f"t = {t[k]:.6g} s; nothing was written: choose smaller or other values (sizefx simulate "
                "--print-effects lists every key and its range)"
            )
        raise ConfigError(
            f"{out}: {dataset} would read {values[k, column]:.6g} (SI) at t = {t[k]:.6g} s, axis {'xyz'[column]}, "
            f"beyond the telemetry contract's physical limit (+-{schema['sample_limits'][dataset]:g}) that every "
            f"reader refuses; this comes from {_blame(scenario, effects, name)}; nothing was written: choose "
            "smaller values or a gentler motion (sizefx simulate --print-effects lists every key and its range)"
        )


def _refuse_implausible(out, scenario: str, effects: EffectModel, tel: Telemetry):
    """Refuse a record that ``sizefx inspect`` would refuse by default (:func:`sizefx.sanity.implausible`
    on the rows of :func:`sizefx.sanity.sample_blocks`), naming what makes it so; the atomic writer
    leaves nothing behind."""
    from ..sanity import implausible

    found = implausible(tel)
    if found is None:
        return
    raise ConfigError(
        f"{out}: sizefx inspect would refuse this record by its physics check: {found.dataset} {found.detail}; "
        f"this comes from {_blame(scenario, effects, found.what)}; nothing was written: choose smaller values or "
        "a gentler motion (sizefx simulate --print-effects lists every key and its range), or pass --no-units-check "
        "to write it anyway for tests of the checkers (sizefx inspect then needs --no-units-check too)"
    )


class _Sample:
    """The rows of a record being written that :func:`_refuse_implausible` judges it on (the whole
    record, or the blocks of a long one: :func:`sizefx.sanity.sample_blocks`), copied from the
    chunks as they pass, so that the check never reads the file back: memory bounded by
    :data:`sizefx.sanity.SAMPLE_ROWS` rows of time, gyro and accel, and the reference rows
    (time, attitude) within the blocks' time spans.

    ``reference(time_s) -> quat_nb``: the reference attitude, known before any row is written,
    where the blocks look for the stretches that turn.
    """

    def __init__(self, n_samples: int, rate_hz: float, reference=None):
        from ..sanity import sample_blocks

        blocks = np.array(sample_blocks(n_samples, rate_hz, reference), dtype=np.int64).reshape(-1, 2)
        self.starts, self.stops = blocks[:, 0], blocks[:, 1]
        self.offsets = np.r_[0, np.cumsum(self.stops - self.starts)]  #: where each block's rows go
        self.half_period_s = 0.5 / rate_hz
        rows = int(self.offsets[-1])
        self.time_s = np.empty(rows)
        self.gyro = np.empty((rows, 3))
        self.accel = np.empty((rows, 3))
        self.reference: list[tuple[np.ndarray, np.ndarray]] = []

    def add_imu(self, first_row: int, t, gyro, accel):
        """Keep the rows of a chunk (rows ``first_row ...``) that fall in a block."""
        stop = first_row + t.shape[0]
        # only the blocks the chunk meets (a slow record has thousands of short blocks)
        for i in range(np.searchsorted(self.stops, first_row, side="right"), np.searchsorted(self.starts, stop)):
            b0, b1, at = self.starts[i], self.stops[i], self.offsets[i]
            lo, hi = max(b0, first_row), min(b1, stop)
            into = slice(at + lo - b0, at + hi - b0)
            self.time_s[into] = t[lo - first_row : hi - first_row]
            self.gyro[into] = gyro[lo - first_row : hi - first_row]
            self.accel[into] = accel[lo - first_row : hi - first_row]

    def add_reference(self, t_ref, quat_nb):
        """Keep the reference rows within a block's time span (once every IMU row is in). A reference
        stamp is an IMU stamp (the rates divide) computed apart: half a sample period's slack."""
        first = self.time_s[self.offsets[:-1]] - self.half_period_s
        last = self.time_s[self.offsets[1:] - 1] + self.half_period_s
        block = np.searchsorted(first, t_ref, side="right") - 1
        keep = (block >= 0) & (t_ref <= last[np.maximum(block, 0)])
        if np.any(keep):
            self.reference.append((t_ref[keep], quat_nb[keep]))

    def telemetry(self, form: str, site: Site) -> Telemetry:
        """The sample as a record in memory, the breaks between blocks as declared gaps."""
        from ..io.gaps import find_imu_gaps

        ref = None
        if self.reference:
            ref = Reference(*(np.concatenate([piece[k] for piece in self.reference]) for k in range(2)))
            self.reference = []
        t = self.time_s
        tel = Telemetry(time_s=t, form=form, reference=ref, site=site, gaps=find_imu_gaps(t, declared=True))
        if form == "rates":
            tel.gyro_rad_s, tel.accel_mps2 = self.gyro, self.accel
        else:
            tel.dtheta_rad, tel.dvel_mps = self.gyro, self.accel
        return tel
