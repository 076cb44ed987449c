"""The pairs a record cannot tell apart, after the fit, and what it cannot reveal.

For :func:`sizefx.diagnose.fit.diagnose`: the findings the grade resolves from their aliases
(:func:`_resolved`), the other halves of the pairs counted among the hidden parameters
(:func:`_with_aliases`), and the :class:`~sizefx.diagnose.records.NotRevealed` entries, each alias
with the motions that would separate it (:func:`_not_revealed`, :func:`_named`).
"""

from __future__ import annotations

import numpy as np

from .aliases import library_normals, resolve, separating_motions
from .budget import Parts
from .candidates import CANDIDATES
from .records import NotRevealed, named
from .theta import PARAMS

__all__: list[str] = []


def _with_aliases(unrevealed: dict, aliased, outside) -> dict:
    """The selection's ``unrevealed`` (key -> (candidate, parameters, reason)) and the other half of
    each pair the record cannot tell apart: the effect of a selected pair the model does not keep
    (``aliased``: (kept, gone, rho)) and the candidate left out that a selected effect is no finding
    beside (``outside``). Held at their start values, they move what is estimated beside them (the
    antisymmetric gyro misalignment of one axis and a mount, dropped as a pair on a turntable, went
    whole into the other axis's misalignment: 86 sigma off on a development-range turntable, seed
    206), so :func:`sizefx.diagnose.aliases.hidden_parameters` counts them: fitted beside the model
    with their plausible ranges as priors, so that the record still pins what it can of the pair."""
    out = dict(unrevealed)
    counted = {j for _, params, _ in unrevealed.values() for j in params}
    gone = [(g.cand, tuple(g.active)) for _, g, _ in aliased] + [(cand, tuple(seen)) for _, cand, seen, _ in outside]
    for cand, params in gone:
        params = tuple(j for j in params if j not in counted)  # a pair's half may also be another's outside
        if params:
            counted.update(params)
            out[f"{cand.key} (alias)"] = (cand, params, "left out beside a selected effect nearly collinear with it")
    return out


def _with_left_out(entries: dict, chosen) -> dict:
    """``entries`` (key -> (candidate, parameters, reason), as :func:`_with_aliases` gives them) and
    every other candidate parameter the selected model ``chosen`` does not hold: what the selection
    left out as not significant is held at its start value by the fit, and may move the findings'
    estimates by more than their errors (:data:`sizefx.diagnose.aliases.CONSIDER_REACH`)."""
    out = dict(entries)
    counted = {j for _, params, _ in entries.values() for j in params} | {j for c in chosen for j in c.active}
    for cand in CANDIDATES:
        params = tuple(j for j in cand.idx if j not in counted)
        if params:
            counted.update(params)
            out[f"{cand.key} (left out)"] = (cand, params, "left out by the selection")
    return out


def _resolved(nrm, free, aliased, outside, theta, theta0, grade, level, parts: Parts, log):
    """The findings the grade resolves from their aliases (:func:`sizefx.diagnose.aliases.resolve`):
    ``({finding key: Alternative}, the budget's aliases part [free, free])``. ``aliased``: selected
    pairs, the first kept; ``outside``: a selected effect and a candidate left out; ``parts``: the
    errors' sandwich and the parts' factors, against which a finding must stay significant."""
    resolved: dict = {}
    alias_cov = np.zeros((free.size, free.size))
    factors = np.array([parts.factors.get(j, 1.0) for j in free.tolist()])
    widened = parts.sandwich * np.outer(factors, factors)
    pairs = [(keep, gone.cand, gone.active, rho) for keep, gone, rho in aliased]
    pairs += [(c, cand, seen, rho) for c, cand, seen, rho in outside]
    for finding, alt, seen, rho in pairs:
        if finding.cand.key in resolved:
            continue
        got = resolve(nrm, free, finding, alt, seen, theta, theta0, grade, rho, widened, level)
        if got is not None:
            resolved[finding.cand.key] = got[0]
            alias_cov += got[1]
            log.append(f"{finding.cand.key} kept against {alt.key}: {got[0].reason}")
    return resolved, alias_cov


class _Separation:
    """The motions that would separate two groups of parameters of the model ``free``
    (:func:`sizefx.diagnose.aliases.separating_motions`), the library's normal matrices formed
    once, on first use, at the model ``theta`` with the record's ``weights``."""

    def __init__(self, nrm, free, theta, weights):
        self.nrm, self.free, self.theta, self.weights = nrm, free, theta, weights
        self.N_record = nrm.N.sum(0)
        self.normals: dict = {}

    def __call__(self, a, b) -> tuple:
        if not self.normals:
            self.normals.update(library_normals(self.theta, self.weights))
        rest = np.setdiff1d(self.free, np.union1d(np.asarray(a, dtype=int), np.asarray(b, dtype=int)))
        return separating_motions(self.N_record, self.nrm.rows, list(a), list(b), rest, self.normals)


def _not_revealed(unrevealed, aliased, outside, nuisance, weak, chosen, separated_by: _Separation) -> list:
    """What the record cannot reveal, as :class:`~sizefx.diagnose.records.NotRevealed` entries: the
    parameters the motion does not excite (``unrevealed``, from the selection); the pairs it cannot
    tell apart (``aliased``: both selected, the model carrying their sum as the first; ``outside``:
    a selected effect and a candidate left out); the candidates fitted beside a finding
    (``nuisance``) and the findings no longer one beside them (``weak``). Each alias names the
    motions that would separate it (``separated_by``)."""
    unrev = [
        NotRevealed(cand.id, cand.channel, tuple(PARAMS[j].label for j in hidden), reason)
        for cand, hidden, reason in unrevealed.values()
    ]
    for keep, gone, rho in aliased:
        motions = separated_by(keep.active, gone.active)
        for me, other in ((keep, gone), (gone, keep)):
            unrev = _named(
                unrev,
                me.cand,
                me.active,
                f"indistinguishable from {other.cand.key} on this motion (canonical correlation {rho:.4f}); "
                f"the extended model carries their sum as {keep.cand.key}",
                motions,
            )
    for c, cand, seen, rho in outside:
        motions = separated_by(c.active, seen)
        for me, other, params in ((c.cand, cand.key, c.active), (cand, c.cand.key, cand.idx)):
            if any((u.id, u.channel) == (me.id, me.channel) and "on this motion" in u.reason for u in unrev):
                continue
            unrev = _named(
                unrev,
                me,
                params,
                f"indistinguishable from {other} on this motion (canonical correlation {rho:.4f}); "
                f"the extended model carries it as {c.cand.key}",
                motions,
            )
    finding_of = {c.cand.key: c for c in chosen}
    for n, of, rho in nuisance:
        unrev = _named(
            unrev,
            n.cand,
            n.active,
            f"nearly indistinguishable from {of} on this motion (canonical correlation {rho:.4f}): fitted "
            f"beside it, so that {of}'s estimate and error do not assume it absent; not a finding of its own",
            separated_by(n.active, finding_of[of].active),
        )
    for c, n, rho, why in weak:
        unrev = _named(
            unrev,
            c.cand,
            c.active,
            f"nearly indistinguishable from {n.cand.key} on this motion (canonical correlation {rho:.4f}): "
            f"fitted together, it is no longer a finding ({why}); the extended model carries both",
            separated_by(c.active, n.active),
        )
    return unrev


def _undetermined(
    unrev: list, reported, undetermined: dict, lent: dict, sig: dict, lenders: dict, separated_by: _Separation, log
) -> list:
    """``unrev`` with the components of findings the record does not measure named (``undetermined``:
    finding key -> parameters; ``lent``: parameter -> the share of its variance the priors of
    parameters the record cannot tell from it make up, :meth:`sizefx.diagnose.budget.ErrorBudget.borrowed`;
    ``lenders``: parameter -> (candidate, parameter) whose prior moves it most,
    :func:`sizefx.diagnose.aliases.strongest_hidden`), grouped by that parameter, with the motions
    that would separate them (``separated_by``); ``log`` takes a line per finding."""
    for c in reported:
        groups: dict = {}
        for j in undetermined.get(c.cand.key, ()):
            groups.setdefault(lenders.get(j), []).append(j)
        for lender, params in groups.items():
            errors = "; ".join(
                f"{PARAMS[j].label} +- {sig[j] / PARAMS[j].per_unit:.3g} {PARAMS[j].unit}, "
                f"{100 * lent[j]:.0f} % of its variance"
                for j in params
            )
            reason = f"its error comes from the priors of parameters this record cannot tell it from ({errors})"
            motions: tuple = ()
            if lender is not None:
                cand, h = lender
                reason += f", most of all {cand.key} {PARAMS[h].label}"
                motions = separated_by(params, [h])
            reason += ": the record does not measure it; the extended model carries its estimate"
            unrev = _named(unrev, c.cand, params, reason, motions)
        if groups:
            log.append(f"{c.cand.key}: not measured: {', '.join(PARAMS[j].label for j in undetermined[c.cand.key])}")
    return unrev


def _named(unrev: list, cand, params, reason: str, separated_by=()) -> list:
    """``unrev`` with the candidate's parameters ``params`` (indices into theta) named for ``reason``
    (:func:`sizefx.diagnose.records.named`), and the motions that would separate it."""
    return named(
        unrev, NotRevealed(cand.id, cand.channel, tuple(PARAMS[j].label for j in params), reason, tuple(separated_by))
    )
