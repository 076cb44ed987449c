"""What a structure left in a residual is: its kind, what a finding of it needs, and its sentence.

:func:`sizefx.diagnose.structure.unexplained` tests each channel for the :data:`KINDS` in order,
each kind with its share of the family-wise level (:data:`ALPHA_SHARE`), and words each finding
here, in report units with a plausible physical cause.

Size floor
----------
A structure is reported only if its RMS over the record is at least :data:`SIZE_FLOOR` times the
channel's white noise sigma (``noise_sigma``): a line ``A / sqrt(2)``, a drift its RMS about the
mean, a step ``h sqrt(p (1 - p))`` (``p`` the share of the record before it), a correlation
``|beta| rms(x)``. Below it the structure adds less than 1 % to the residual's variance, and a
huge record makes it significant without making it worth a sentence.
"""

from __future__ import annotations

from ..constants import DEG_PER_H, MICRO_G
from .theta import CHANNELS

__all__ = ["KINDS", "ALPHA_SHARE", "SIZE_FLOOR"]

#: The kinds of structure, in the order they are tested.
KINDS = ("correlation", "step", "trend", "spectral_line")
#: Share of the family-wise level per kind (they sum to one: weighted Bonferroni).
ALPHA_SHARE = {kind: 0.25 for kind in KINDS}
#: Smallest reported structure, as its RMS over the record relative to the white noise sigma:
#: 0.1 adds 1 % to the residual's variance, less than the scatter of a fitted sigma is worth.
SIZE_FLOOR = 0.1

#: Physical causes, per kind, for the sentences.
_CAUSE = {
    "spectral_line": "a vibration or structural resonance outside the model",
    "trend": "a drifting bias (temperature?)",
    "step": "a step: a re-mount, a range switch or a reference jump",
}


def _unit(c):
    return "rad/s" if c < 3 else "m/s^2"


def _report(c, value_si):
    """A value of channel c in report units, as text."""
    if c < 3:
        return f"{value_si / DEG_PER_H:.3g} deg/h"
    return f"{value_si / MICRO_G:.3g} ug"


def _regressor_cause(name, channel):
    if name in ("omega_sq", "omega2", "omega_squared"):
        return f"an effect proportional to omega^2 on {channel} that no candidate explains"
    if name.startswith("omegadot"):
        return (
            f"an effect proportional to angular acceleration on {channel} (an arm or a delay the model does not hold)"
        )
    if name.startswith("omega"):
        return f"a rate-dependent effect on {channel} (scale-factor nonlinearity, a rate-dependent misalignment)"
    if name.startswith("f_"):
        return f"a specific-force dependence on {channel} (g-sensitivity or nonlinearity beyond the candidates)"
    return f"an effect following {name} on {channel} that no candidate explains"


def _sentence(c, f, t, keep):
    channel = CHANNELS[c]
    kind = f["kind"]
    if kind == "spectral_line":
        return f"{channel}: a line at {f['frequency_hz']:.2f} Hz, amplitude {_report(c, f['size'])}: {_CAUSE[kind]}"
    if kind == "trend":
        return (
            f"{channel}: a drift of {_report(c, f['signed'])} over {f['span_s']:.0f} s (peak to peak "
            f"{_report(c, f['size'])}): {_CAUSE[kind]}"
        )
    if kind == "step":
        return f"{channel}: a step of {_report(c, f['signed'])} at t = {f['time_s']:.3f} s: {_CAUSE[kind]}"
    return (
        f"{channel}: follows {f['regressor']}, {_report(c, f['size'])} RMS: {_regressor_cause(f['regressor'], channel)}"
    )
