"""What a diagnosis lists beside its findings, as typed records: warnings, rejections, what the
record cannot reveal, and what ``sizefx diagnose`` did with the extended model after the fit.

Warnings are made by :mod:`.integrity` (the reference) and :mod:`.fit` (the estimates and the
errors), rejections and not-revealed entries by :mod:`.fit` only, :class:`ModelChecks` by the stage
(:func:`sizefx.diagnose.run`); :mod:`.report` reads them, and :meth:`as_dict` alone turns the first
three into the ``sizefx/diagnosis/2`` fields.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ReportWarning", "Rejection", "NotRevealed", "ModelChecks", "named"]


@dataclass(frozen=True)
class ReportWarning:
    """Something that may make the result untrustworthy, said first in the report."""

    kind: str  #: snake_case: reference_glitch, implausible_estimate, inconsistent_blocks, overfit, ...
    message: str  #: one sentence for the user
    time_s: float | None = None  #: where in the record, when it is a moment [s, IMU clock]
    size: float | None = None  #: how large, in ``unit`` (None: no unit)
    unit: str | None = None
    quantity: str | None = None  #: the reference's quantity a reference warning is about (attitude, ...)

    def as_dict(self) -> dict:
        out = {"kind": self.kind, "time_s": self.time_s, "size": self.size, "unit": self.unit, "message": self.message}
        if self.quantity is not None:
            out["quantity"] = self.quantity
        return out


@dataclass(frozen=True)
class Rejection:
    """An effect the selection took but the checks refused, with why and what is more likely."""

    id: str
    channel: str | None
    parameters: dict  #: label -> value in ``unit``
    unit: str
    reason: str
    likely: str | None = None

    @property
    def key(self) -> str:
        return f"{self.id}:{self.channel}" if self.channel else self.id

    def as_dict(self) -> dict:
        out = {
            "id": self.id,
            "channel": self.channel,
            "parameters": dict(self.parameters),
            "unit": self.unit,
            "reason": self.reason,
        }
        if self.likely is not None:
            out["likely"] = self.likely
        return out


@dataclass(frozen=True)
class NotRevealed:
    """An effect, or some of its parameters, the record cannot reveal, and why."""

    id: str
    channel: str | None
    parameters: tuple  #: parameter labels (``r_x[z]``, ``x->y``)
    reason: str
    #: motions that would separate it from what it is confused with (:mod:`.aliases`): (motion, canonical correlation)
    separated_by: tuple = ()

    @property
    def key(self) -> str:
        return f"{self.id}:{self.channel}" if self.channel else self.id

    def as_dict(self) -> dict:
        out: dict = {"id": self.id, "channel": self.channel, "parameters": list(self.parameters), "reason": self.reason}
        if self.separated_by:
            out["separated_by"] = [{"motion": m, "canonical_correlation": rho} for m, rho in self.separated_by]
        return out


@dataclass(frozen=True)
class ModelChecks:
    """What ``sizefx diagnose`` did with the extended model after the fit (:func:`sizefx.diagnose.run`):
    wrote it, navigated with it, and applied it to other records. The reports give them beside the fit
    (:func:`sizefx.diagnose.to_json`, :func:`sizefx.diagnose.format_report`); a fit alone has none."""

    model_path: str | None = None  #: the extended model written (``--model-out``)
    #: the record's free-inertial horizontal error under the start and the extended model,
    #: ``{"duration_s", "before", "after"}`` (:func:`sizefx.diagnose.navigation_gain`); None: not navigated
    navigation: dict | None = None
    #: the same over each stretch of the record the cross-validation held out, from the reference at its
    #: start, also under the model fitted without it:
    #: ``{"windows": [{"t0_s", "t1_s", "duration_s", "before", "after", "in_sample"}]}``; None: not navigated
    window_navigation: dict | None = None
    #: the extended model on other records (``--validate-on``): an
    #: :class:`~sizefx.diagnose.holdout.OutOfSample` each
    validated_on: tuple = ()


def named(entries: list, entry: NotRevealed) -> list:
    """``entries`` with ``entry`` added, its parameters taken out of the entries of the same effect
    that named them before (an entry left with none is dropped): a component named for another reason
    (a mount's z the motion does not excite, beside its x and y named indistinguishable) keeps its own."""
    out = []
    for u in entries:
        if (u.id, u.channel) == (entry.id, entry.channel):
            rest = tuple(p for p in u.parameters if p not in entry.parameters)
            if not rest:
                continue
            u = NotRevealed(u.id, u.channel, rest, u.reason, u.separated_by)
        out.append(u)
    out.append(entry)
    return out
