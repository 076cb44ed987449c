"""Which effects the residual supports: forward selection, and the pairs a record cannot separate.

One Gauss-Newton pass's selection, linearised at the current estimate, with parameters not
selected pinned at their nominal values, on the block-wise normal equations of
:mod:`sizefx.diagnose.normal`. :func:`select` is a forward selection in which a candidate enters
only when it passes three gates:

(a) the Bayesian information criterion: it lowers the weighted residual by more than ``k ln(n)``
    (for one parameter 3.7 sigma at 1e6 rows);
(b) a **robust Wald test** at a family-wise level: its parameters, fitted together with those
    already selected, differ from the start model with a p-value under ``alpha / m`` (Bonferroni
    over the ``m`` candidates; ``alpha`` = :data:`FAMILY_ALPHA`) using the block-sandwich covariance
    (:func:`sizefx.diagnose.normal.covariance`, never smaller than the white one): coloured
    residuals, which inflate the information criterion's gain, do not pass this gate;
(c) it lowers the cross-validated error (interleaved folds of blocks).

Of the candidates that pass (a), the one that improves the criterion most is tried first, unless a
more common effect (:data:`sizefx.diagnose.candidates.PRIORITY`) scores within one parameter's
penalty of it; a candidate failing (b) or (c) gives way to the next.

:func:`revealed` removes, before a candidate is scored, the parameters the motion does not excite
(regressor RMS over sqrt(VIF) under ``Param.min_excitation``); :func:`why_hidden` says why, in
words. :func:`aliased_pairs` finds, after the selection, pairs of selected effects whose regressors
are nearly collinear on this motion (largest canonical correlation above :data:`ALIAS_CORRELATION`):
the record cannot say which of the two it sees, so neither is a separate finding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from .candidates import CANDIDATES, PRIORITY, Candidate
from .normal import Normal, canonical_correlation, covariance, cv_error, excitation, solve, wald
from .theta import PARAMS

__all__ = [
    "Chosen",
    "aliased_pairs",
    "aliases_outside",
    "honest",
    "nuisance_aliases",
    "revealed",
    "robust_p",
    "select",
    "why_hidden",
    "ALIAS_CORRELATION",
    "FAMILY_ALPHA",
    "NUISANCE_CORRELATION",
]

#: Family-wise false-alarm level of the robust Wald gate, over every candidate of a step.
FAMILY_ALPHA = 0.01
#: Two effects whose regressors reach this canonical correlation (given the others) are
#: indistinguishable on the record's motion whatever the noise: their standard errors grow by
#: 1/sqrt(1 - rho^2) >= 70 over the orthogonal case, and the smallest model error anywhere moves one
#: into the other. Below it, the robust Wald test decides (:func:`aliased_pairs`).
ALIAS_CORRELATION = 0.9999


def honest(white, robust):
    """The robust covariance, scaled up where its diagonal falls below the white one's (the block
    sandwich is itself an estimate, +-14 % with 100 blocks: it must not make a parameter look
    better known than white noise would)."""
    if white.size == 0:
        return robust
    r, w = np.diag(robust), np.diag(white)
    # the robust correlations at the larger of the two variances: the robust covariance with row and
    # column i scaled by sqrt(max(1, w_i / r_i)), formed so that nothing overflows where a robust
    # variance is nil or near the float limit (the scale went to 1e150 and its square to inf, and a
    # nil row times it to NaN); a parameter whose blocks' scores are all nil takes its white variance
    pos = r > 0
    s_r = np.sqrt(np.where(pos, r, 1.0))
    corr = np.where(np.outer(pos, pos), robust / np.outer(s_r, s_r), 0.0)
    np.fill_diagonal(corr, 1.0)
    s = np.sqrt(np.maximum(np.maximum(r, w), 0.0))
    return corr * np.outer(s, s)


@dataclass
class Chosen:
    """A candidate the selection took, split into what the record reveals and what it cannot."""

    cand: Candidate
    active: tuple  #: the parameters of the candidate the record reveals
    hidden: tuple  #: those it cannot


def _free(chosen) -> np.ndarray:
    return np.array(sorted({j for c in chosen for j in c.active}), dtype=int)


def robust_p(nrm: Normal, chosen, offset, which=-1, factors=None) -> float:
    """p-value of the robust Wald test of ``chosen[which]``'s parameters, fitted with all of ``chosen``;
    ``factors`` {param: factor} widen the standard errors first (the consistency check's)."""
    free = _free(chosen)
    x, white, robust = covariance(nrm, free, offset)
    cov = honest(white, robust)
    if factors:
        f = np.array([factors.get(j, 1.0) for j in free.tolist()])
        cov = cov * np.outer(f, f)
    pos = [int(np.searchsorted(free, j)) for j in chosen[which].active]
    # x is the step from the linearisation point; the test is of the value against the start model
    return float(chi2.sf(wald(x - offset[free], cov, pos), len(pos)))


def select(nrm: Normal, offset, penalty, alpha: float = FAMILY_ALPHA, start=()):
    """Forward selection (module docstring), from the effects ``start`` (:class:`Chosen`, kept
    whatever the record says of them) on. Returns (chosen, unrevealed {key: (candidate, hidden
    params, reason)}, log lines)."""
    N, b, yy = nrm.total()
    chosen: list[Chosen] = list(start)
    log = []
    level = alpha / len(CANDIDATES)
    _, rss, _ = solve(N, b, yy, _free(chosen), offset)
    cv = cv_error(nrm, _free(chosen), offset)
    while True:
        scored = []
        for cand in CANDIDATES:
            if any(c.cand == cand for c in chosen):
                continue
            active, hidden = revealed(nrm, _free(chosen), cand)
            if not active:
                continue
            trial = chosen + [Chosen(cand, tuple(active), tuple(hidden))]
            _, rss_new, _ = solve(N, b, yy, _free(trial), offset)
            gain = rss - rss_new
            score = gain - penalty * len(active)  # the criterion's improvement: fewer parameters win ties
            if score > 0:
                scored.append((score, PRIORITY.index(cand.id), gain, trial, rss_new))
        entered = None
        while scored:
            # The best score goes first unless a more common effect (PRIORITY) scores within one
            # parameter's penalty of it: near-collinear candidates (a z bias and a z scale factor under
            # constant gravity) are then explained the ordinary way.
            top = max(s[0] for s in scored)
            pick = min((s for s in scored if s[0] >= top - penalty), key=lambda s: s[1])
            scored.remove(pick)
            _, _, gain, trial, rss_new = pick
            key = trial[-1].cand.key
            p = robust_p(nrm, trial, offset)
            if p > level:
                log.append(
                    f"{key}: passes the information criterion but not the robust test (p = {p:.2g} > {level:.2g})"
                )
                continue
            cv_new = cv_error(nrm, _free(trial), offset)
            if cv_new >= cv:
                log.append(f"{key}: passes the information criterion but not cross-validation")
                continue
            entered = (trial, rss_new, cv_new, gain, p)
            break
        if entered is None:
            break
        chosen, rss, cv = entered[0], entered[1], entered[2]
        log.append(
            f"{chosen[-1].cand.key}: chi2 gain {entered[3]:.1f} (threshold "
            f"{penalty * len(chosen[-1].active):.1f}), robust p = {entered[4]:.2g}"
        )
    unrevealed = {}
    free = _free(chosen)
    for cand in CANDIDATES:
        mine = [c for c in chosen if c.cand == cand]
        if mine:
            if mine[0].hidden:
                unrevealed[cand.key] = (cand, mine[0].hidden, why_hidden(nrm, cand, mine[0].hidden, chosen))
            continue
        active, hidden = revealed(nrm, free, cand)
        if hidden:
            unrevealed[cand.key] = (cand, tuple(hidden), why_hidden(nrm, cand, hidden, chosen))
    return chosen, unrevealed, log


#: Pairs are examined only from this canonical correlation on: below it, two effects that are each
#: significant alone are also significant together.
_PREFILTER_CORRELATION = 0.9


def _collinear_left_out(nrm: Normal, chosen, skip=()):
    """``(i, candidate, seen, rho)`` for each selected effect ``chosen[i]`` and each candidate the
    selection did not take (nor named in ``skip``), with ``seen`` the candidate's parameters the
    record reveals beside the others and ``rho`` their largest canonical correlation with
    ``chosen[i]``'s, given the rest, from :data:`_PREFILTER_CORRELATION` on."""
    N = nrm.N.sum(0)
    taken = {c.cand for c in chosen}
    for i, c in enumerate(chosen):
        rest = sorted({j for m, o in enumerate(chosen) if m != i for j in o.active})
        for cand in CANDIDATES:
            if cand in taken or cand.key in skip:
                continue
            # only what the rest of the model leaves revealed of the candidate: a part the rest already
            # hides (an accelerometer-z quadratic term under constant gravity, beside the z bias; a gyro's
            # g-sensitivity to f_z beside its bias) is degenerate whatever chosen[i] is, no alias of it
            # (its canonical correlation with any group would read 1)
            seen = [j for j in revealed(nrm, np.asarray(rest, dtype=int), cand)[0] if j not in rest]
            if not seen:
                continue
            rho = canonical_correlation(N, c.active, seen, rest)
            if rho >= _PREFILTER_CORRELATION:
                yield i, cand, seen, rho


def aliases_outside(nrm: Normal, chosen, offset, level) -> list:
    """``(i, candidate, seen, rho)``: a selected effect ``chosen[i]`` that is no longer significant (robust
    Wald p above ``level``) once a candidate the selection did *not* take is fitted with it, their
    regressors being nearly collinear on this motion. The selection took one of two explanations the
    record cannot tell apart (a level tilt or the horizontal accelerometer biases on a sway): the one
    it took is no finding, unless the grade rules the other out (:mod:`.aliases`). ``seen``: the
    candidate's parameters the record reveals beside the others."""
    out = []
    for i, cand, seen, rho in _collinear_left_out(nrm, chosen):
        trial = chosen + [Chosen(cand, tuple(seen), ())]
        if rho >= ALIAS_CORRELATION or robust_p(nrm, trial, offset, which=i) > level:
            out.append((i, cand, tuple(seen), rho))
    return out


#: A candidate the selection left out whose regressors reach this canonical correlation with a
#: selected effect's (given the rest) is fitted beside it (:func:`nuisance_aliases`): what "nearly
#: collinear" means here, the same correlation from which :func:`aliases_outside` looks at a pair.
NUISANCE_CORRELATION = _PREFILTER_CORRELATION


def nuisance_aliases(nrm: Normal, chosen, skip=()) -> list:
    """``(nuisance, of, rho)``: candidates the selection did not take whose revealed parameters are
    nearly collinear (:data:`NUISANCE_CORRELATION` up to :data:`ALIAS_CORRELATION`, from which the
    two are one to the record and :func:`aliases_outside` names them) on this motion with a selected
    effect ``of``
    (a key), each as a :class:`Chosen` to fit beside the selection; ``skip``: candidate keys left out.

    A selected effect's standard error is conditional on the others being what the fit assumes:
    those left out at their start values. Beside a nearly collinear one left out (an accelerometer-z
    scale factor under constant gravity, with the z bias out), that error holds only if the other is
    exactly at its start value; the record cannot say so. Fitted together, the selected effect
    carries the error it has with the other free, 1/sqrt(1 - rho^2) times wider, and its estimate
    loses the other's pull."""
    out: list[tuple[Chosen, str, float]] = []
    for i, cand, seen, rho in _collinear_left_out(nrm, chosen, skip):
        if any(n.cand == cand for n, _, _ in out):
            continue
        if NUISANCE_CORRELATION <= rho < ALIAS_CORRELATION:  # beyond, aliases_outside names the pair
            out.append((Chosen(cand, tuple(seen), ()), chosen[i].cand.key, rho))
    return out


def aliased_pairs(nrm: Normal, chosen, offset, level) -> list:
    """Pairs ``(i, k, rho)`` of selected effects (indices into ``chosen``) that the record cannot tell
    apart: one of them is not significant given all the others (robust Wald p above ``level``), and
    its regressors are nearly collinear with the other's on this motion (largest canonical
    correlation given the rest); or the correlation reaches :data:`ALIAS_CORRELATION` outright."""
    N = nrm.N.sum(0)
    out: list[tuple[int, int, float]] = []
    for i in range(len(chosen)):
        weak = robust_p(nrm, chosen, offset, which=i) > level
        best = None
        for k in range(len(chosen)):
            if k == i:
                continue
            rest = sorted({j for m, c in enumerate(chosen) if m not in (i, k) for j in c.active})
            rho = canonical_correlation(N, chosen[i].active, chosen[k].active, rest)
            if rho >= ALIAS_CORRELATION or (weak and rho >= _PREFILTER_CORRELATION):
                if best is None or rho > best[1]:
                    best = (k, rho)
        if best is not None and not any({i, best[0]} == {a, b} for a, b, _ in out):
            out.append((min(i, best[0]), max(i, best[0]), best[1]))
    return out


def revealed(nrm: Normal, free, cand):
    """Split the candidate's parameters into those the record reveals (jointly with ``free``) and the rest."""
    active = list(cand.idx)
    while active:
        trial = np.array(sorted(set(free.tolist()) | set(active)), dtype=int)
        ex = excitation(nrm, trial)
        worst = min(active, key=lambda j: ex[j] / PARAMS[j].min_excitation)
        if ex[worst] >= PARAMS[worst].min_excitation:
            break
        active.remove(worst)
    return active, [j for j in cand.idx if j not in active]


def why_hidden(nrm: Normal, cand, hidden, chosen):
    """Plain reason a parameter set cannot be revealed: the motion, or confusion with a selected effect."""
    alone = excitation(nrm, np.array(hidden, dtype=int))
    if any(alone[j] < PARAMS[j].min_excitation for j in hidden):
        return "the motion in this record does not excite it"
    culprits = []
    for c in chosen:
        if c.cand == cand:
            continue
        rest = [o for o in chosen if o is not c and o.cand != cand]
        trial = np.array(sorted({j for o in rest for j in o.active} | set(hidden)), dtype=int)
        ex = excitation(nrm, trial)
        if all(ex[j] >= PARAMS[j].min_excitation for j in hidden):
            culprits.append(c.cand.key)
    if culprits:
        return "indistinguishable in this record from " + " or ".join(culprits)
    if not [c for c in chosen if c.cand != cand]:
        return "its components cannot be told apart from each other in this record"
    return "indistinguishable in this record from the effects found together"
