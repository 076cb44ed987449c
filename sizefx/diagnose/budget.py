"""The error budget of a diagnosis: each estimate's error, in named parts.

A standard error is a promise about how far the estimate would move on another record of the same
set-up. Its parts, in the order they are formed (all in SI, over the parameters ``free`` the model
estimates, findings and the nuisance fitted beside them):

- **white**: ``N^-1`` of the weighted normal equations (:func:`sizefx.diagnose.normal.covariance`),
  right if the weights were the inverse noise variances and the noise white;
- **sandwich**: ``N^-1 M N^-1`` with ``M`` the variance of the scores under a model of the
  residual's spectrum (:mod:`.spectrum`): what varies within a block against the residual's
  variance there, the blocks' sums against the covariance of its block means, from white noise
  plus a power law fitted to their periodogram. Each parameter takes the noise at the frequencies
  of its regressor. (The selection's tests use the long-run block sandwich instead, never under
  the white covariance: :func:`sizefx.diagnose.selection.honest`.)
- **parts**: the record's contiguous parts fitted alone (:mod:`.consistency`): the variance of an
  effect of each part beyond its noise, estimated from their scatter (a random effect,
  DerSimonian-Laird) where they disagree beyond chance, widens each error by what it adds to the
  whole record's estimate (:func:`parts_scatter`). The parts cut by rotation rate and by
  translation are checks: their disagreement says the model lacks an effect that follows the
  motion, and is reported as such;
- **aliases**: the candidates nearly collinear with a finding are fitted beside it
  (:func:`sizefx.diagnose.selection.nuisance_aliases`), so they are in ``free`` and in every part
  above; a finding resolved from an alias by plausibility (:mod:`.aliases`) carries the error the
  alternative would bring anywhere in its plausible range;
- **hidden**: the parameters the selection hid but which still move the estimates
  (:func:`sizefx.diagnose.aliases.hidden_fit`): one hidden as indistinguishable anywhere its prior
  allows (:func:`sizefx.diagnose.plausibility.prior_sigma`), one fitted beside the findings (a mount
  about z on a flight) with what the record cannot say of it; a finding not significant with them
  in is no finding. The noise of the other parts (the spectrum, the walk, the parts' scatter) is
  measured on the residual with those fitted beside the findings at their fitted values, weighted
  as the fit was (:func:`sizefx.diagnose.gauss_newton.normal_beside`): what they explain is this
  part's, and left in the residual it would be counted again, as colour;
- **walk**: a random walk of the biases (:mod:`.drift`), measured beside the model: what it adds to
  the estimates' covariance, ``N^-1 H'WZ Q Z'WH N^-1``, large for a parameter whose regressor is as
  slow as the walk (a misalignment on a turntable's long axis segments), nil for a fast one. On a
  channel that walks, the sandwich's model of the spectrum leaves out the colour under the walk's
  series (:data:`sizefx.diagnose.drift.WALK_BINS`), which this part holds: counted once;
- **band**: the choice of band and of what the selection takes beside the model there
  (:func:`band_part`).

:meth:`ErrorBudget.borrowed` says how much of each error the hidden parameters' priors make up:
from :data:`UNDETERMINED_SHARE` on, the record does not measure the parameter.

:meth:`ErrorBudget.covariance` adds them up: ``sandwich * f f' + aliases + hidden + walk + band``
with ``f`` the parts' factors.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from .algebra import long_run_meat
from .candidates import columns_between
from .consistency import block_consistency, motion_groups
from .drift import WALK_BINS, walk_covariance
from .normal import CHUNK_SAMPLES, Normal, Rows, block_scores, covariance, normal_equations, solve
from .plausibility import judge
from .predictor import Predictor
from .records import ReportWarning
from .residual import noise_of, residual_under
from .selection import FAMILY_ALPHA, honest, select
from .spectrum import spectral_meat
from .theta import PARAMS

__all__ = [
    "ErrorBudget",
    "Parts",
    "band_part",
    "error_budget",
    "parts_scatter",
    "BAND_NEIGHBOURS",
    "SHIFT_CHI2",
    "shift_chi2",
    "systematic_shift",
    "UNDETERMINED_SHARE",
]

#: The measured band is resolved to a third of an octave (:mod:`.bandwidth`'s bands, then rounded
#: down to a readable value): the fit is redone at the band a third of an octave below, the
#: selection going on there from the final model (:func:`band_part`). Only below: a band too wide
#: biases the estimates, one too narrow only loses information, so the band below says whether the
#: estimate leans on frequencies it should not have used, and the band above only what was cut.
BAND_NEIGHBOURS = (2.0 ** (-1.0 / 3.0),)

#: A parameter's shift to the band below counts as systematic only beyond chance: its square over
#: the variance of its noise above the chi-square point (1 degree of freedom) at the selection's
#: family-wise level, :data:`sizefx.diagnose.selection.FAMILY_ALPHA`, shared among the record's
#: parameters (:func:`shift_chi2`; this is the point for one parameter).
SHIFT_CHI2 = float(chi2.ppf(1.0 - FAMILY_ALPHA, 1))


@functools.cache
def shift_chi2(count: int) -> float:
    """The chi-square point (1 degree of freedom) a shift's square over its noise variance must
    exceed for one of ``count`` parameters tested together: :data:`sizefx.diagnose.selection.FAMILY_ALPHA`
    shared among them (Bonferroni), so that shifts of noise only make a systematic part in about
    that share of records, whatever their number of parameters."""
    return float(chi2.ppf(1.0 - FAMILY_ALPHA / max(int(count), 1), 1))


#: A component of a finding is not measured by the record, and goes to ``not_revealed``, when this
#: share of its variance or more is the priors of parameters the record cannot tell from it
#: (:meth:`ErrorBudget.borrowed`) and its value lies within that error of its start value
#: (:func:`sizefx.diagnose.judging._as_reported`): its error is then over three times what the
#: record alone gives, and its estimate says more of those priors than of the record (an arm's
#: r_z[z] on a sway about one horizontal axis, beside the z accelerometer's scale factor held
#: within its data sheet: +-73 mm against a white error of 0.59 mm). Chosen on the development
#: range: of 641 parameters, the 31 from 0.9 on had z RMS 0.56 and the 610 under it 0.86 (those
#: from 0.5 to 0.8: 0.95).
UNDETERMINED_SHARE = 0.9


@dataclass(frozen=True)
class Parts:
    """The record's parts fitted alone (:func:`parts_scatter`)."""

    white: np.ndarray  #: [f, f] N^-1
    #: [f, f] from the residual's spectrum (``spectral``), else the long-run block sandwich never under white
    sandwich: np.ndarray
    factors: dict  #: param -> the widening the random effect of the parts in time gives (>= 1; 1 within chance)
    entries: dict  #: param -> the cut that disagrees most, with the pooled figures
    count: int  #: contiguous parts in time
    walk: np.ndarray | None = None  #: [f, f] the biases' walk (:func:`sizefx.diagnose.drift.walk_covariance`)


@dataclass(frozen=True)
class ErrorBudget:
    """Each estimate's error in named parts (module docstring), over the parameters ``free``."""

    free: np.ndarray  #: [f] indices into theta
    parts: Parts
    aliases: np.ndarray | None = None  #: [f, f] the plausible range of the alternatives of resolved aliases
    hidden: np.ndarray | None = None  #: [f, f] the priors of hidden parameters that move the estimates
    walk: np.ndarray | None = None  #: [f, f] the biases' random walk
    band: np.ndarray | None = None  #: [f, f] the band's and the selection's systematic part
    bands: list | None = None  #: the neighbouring bands and what was selected there

    @property
    def factors(self) -> np.ndarray:
        return np.array([self.parts.factors.get(j, 1.0) for j in self.free.tolist()])

    def covariance(self) -> np.ndarray:
        """[f, f]: the sandwich widened to the parts, plus the aliases', the hidden parameters', the
        walk's and the band's parts."""
        f = self.factors
        cov = self.parts.sandwich * np.outer(f, f)
        for extra in (self.aliases, self.hidden, self.walk, self.band):
            if extra is not None:
                cov = cov + extra
        return cov

    def borrowed(self) -> np.ndarray:
        """[f]: the share of each estimate's variance that the hidden parameters' part makes up:
        what the priors of parameters the record cannot tell from it allow, not what the record
        says. (A resolved alias's part is not counted: the finding was tested against its
        alternative anywhere in the alternative's plausible range, and kept as significant there.)"""
        total = np.abs(np.diag(self.covariance()))
        if self.hidden is None:
            return np.zeros_like(total)
        return np.divide(np.abs(np.diag(self.hidden)), total, out=np.zeros_like(total), where=total > 0)

    def sigma(self) -> dict:
        """param -> standard error (SI), all parts in."""
        return dict(zip(self.free.tolist(), np.sqrt(np.abs(np.diag(self.covariance())))))

    def sigma_white(self) -> dict:
        """param -> the white-noise standard error (SI), for comparison."""
        return dict(zip(self.free.tolist(), np.sqrt(np.abs(np.diag(self.parts.white)))))

    def warnings(self) -> list:
        """A parameter whose parts disagree beyond chance, and by how much its error is widened."""
        return [
            ReportWarning(
                "inconsistent_blocks",
                f"{e['effect']} {e['parameter']}: the record's parts (by {e['split']}) disagree "
                f"(chi2/dof {e['chi2_dof']:.1f} over {e['dof']}); "
                + (
                    f"the scatter of its parts in time multiplies its standard error by {e['factor']:.2f}"
                    if e["split"] == "time"
                    else "an effect the model lacks may follow the motion"
                ),
                size=e["chi2_dof"],
            )
            for e in self.parts.entries.values()
            if e["inflated"]
        ]

    def consistency(self, block_s: float) -> dict:
        """The report's ``consistency`` field: the parts' checks, and the band's part when there is one."""
        out: dict = {
            "parts": self.parts.count,
            "block_s": block_s,
            "parameters": [self.parts.entries[j] for j in sorted(self.parts.entries)],
        }
        if self.band is not None:
            sys_sigma = np.sqrt(np.diag(self.band))
            out["systematic"] = {
                "bands": self.bands,
                "parameters": [
                    {
                        "parameter": PARAMS[j].label,
                        "effect": PARAMS[j].effect,
                        "sigma_selection": float(sys_sigma[pos] / PARAMS[j].per_unit),
                        "unit": PARAMS[j].unit,
                    }
                    for pos, j in enumerate(self.free.tolist())
                ],
            }
        return out


def parts_scatter(pred: Predictor, nrm: Normal, free, offset, spectral: bool = False) -> Parts:
    """The white and sandwich covariances of ``free`` at the normal equations ``nrm`` (``offset``:
    the start model minus the estimate), and the widening each parameter's error takes from the
    record's parts fitted alone (:mod:`.consistency`: in time, by rotation rate, by translation).

    ``spectral``: the "sandwich" is the covariance from the residual's spectrum at each regressor's
    frequencies (:func:`sizefx.diagnose.spectrum.spectral_meat`), less the colour the walk's part
    holds, for the errors reported, and the parts are judged against it plus the walk's part: all
    the noise the errors take. Without it, the long-run block sandwich never under the white
    covariance (:func:`sizefx.diagnose.selection.honest`), which the selection's tests use."""
    free = np.asarray(free, dtype=int)
    _, white, robust = covariance(nrm, free, offset)
    sandwich = honest(white, robust)
    noise = sandwich
    walk = walk_covariance(nrm.drift, free, white) if free.size else None
    if spectral and nrm.noise is not None and free.size:
        walked = np.where(nrm.drift.walking, WALK_BINS, 0.0)  # under these bins the walk's part holds the colour
        sandwich = white @ spectral_meat(nrm.noise, free, walked) @ white
        sandwich = 0.5 * (sandwich + sandwich.T)
        noise = sandwich if walk is None else sandwich + walk  # the parts are judged against all the noise
    sig = dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(noise)))))
    sig_white = dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(white)))))
    count, by_time = block_consistency(nrm, free, offset, sig, sig_white)
    cuts = [by_time]
    # the parts by motion are sorted by the reference's motion, never by the IMU's readings: sorted
    # by the accelerometers' own |f| - g, a record without translation is cut by their noise, and
    # each part's bias estimate is biased by it (a false "inconsistent" on a yaw-only tumble)
    rate, translation = pred.motion_statistics(CHUNK_SAMPLES)
    for split, stat in (("rate", rate), ("translation", translation)):
        cuts.append(
            block_consistency(nrm, free, offset, sig, sig_white, motion_groups(nrm, pred.t, stat), split=split)[1]
        )
    factors, entries = {}, {}
    for j in free.tolist():
        mine = [c[j] for c in cuts if j in c]
        if not mine:
            continue
        dof = sum(e["dof"] for e in mine)
        pooled = sum(e["chi2_dof"] * e["dof"] for e in mine) / dof
        worst = max(mine, key=lambda e: (e["inflated"], e["chi2_dof"]))
        factors[j] = by_time[j]["factor"] if j in by_time else 1.0
        tau = by_time[j]["tau"] if j in by_time else 0.0
        entries[j] = {**worst, "pooled_chi2_dof": pooled, "pooled_dof": dof, "factor": float(factors[j]), "tau": tau}
    return Parts(white, sandwich, factors, entries, count, walk)


def band_part(pred: Predictor, rows_of: Rows, nrm: Normal, theta, chosen, theta0, grade):
    """The errors' systematic part from the choice of band and of what the selection takes beside
    the model there.

    The band is measured to a third of an octave, and which marginal effects the selection takes
    beside the arms (an accelerometer-z bias, scale factor or misalignment beside r_z[z]) can change
    from one band to the next: the standard errors, conditional on the band and the selection, do
    not carry that. The final model is refitted at the measured band and at the neighbouring band
    below (:data:`BAND_NEIGHBOURS`) alike: the normal equations are formed at the final estimate
    ``theta``, the selection goes on there from the final model (it may take effects beside it, then
    judged for plausibility as the fit's are; it never drops one) and the model it ends with is
    solved (one Gauss-Newton step: the arms and delays are linear in the prediction to well below
    their errors). The shift ``D`` is the difference of the two refits. Taken against the final
    estimate instead, it held what the fit did beyond the measured band's refit: on
    development-range flights (seed 7), the parameters fitted beside the findings
    (:func:`sizefx.diagnose.aliases.hidden_fit`), which the refits hold at their start values, moved
    an accelerometer bias by 1.6 mg at both bands alike. A neighbour that dropped a finding the
    measured band holds would count the whole finding as the band's error (on a development-range
    flight, seed 13, the x arm dropped at 4.8 Hz put 19 mm into the error of r_y[x], whose sandwich
    error is 2.3 mm): hence the selection goes on from the final model.

    The band above is not refitted: there the fit takes frequencies the band choice left out
    (:mod:`.bandwidth`: the reference's noise, or the spline error of an exact reference at a
    rotor's harmonics), whose bias is what the choice avoids. On development-range flights the arms
    moved by 3-4 mm there (seed 7, at 6.3 Hz against 5 Hz, the shift's noise 0.05-0.5 mm) while the
    final estimates were within 0.12 of their errors of the truth.

    Of ``D^2`` the part beyond the variance of the difference of the two refits is systematic,
    where ``D`` is beyond chance (:func:`systematic_shift`). That variance is the long-run sum over
    the blocks of the differences of their shares of the two estimates' errors
    (:func:`sizefx.diagnose.normal.block_scores`, the neighbour's blocks cut where ``nrm``'s
    start): the noise the two bands share cancels block by block, and what is left is the noise
    between the bands, fast, so that blocks hold it. The covariance added is the mean over the
    neighbours of ``(c D)(c D)'``, ``c`` scaling each component so that the diagonal is that
    systematic part.

    ``chosen``: the model's effects (:class:`sizefx.diagnose.selection.Chosen`); ``nrm``: the
    normal equations in the measured band, whose blocks the refits cut theirs at; ``grade``: the
    plausible ranges. Returns (cov [free, free], bands): (None, None) when the record was fitted in
    its full band."""
    if rows_of.bandwidth_hz is None:
        return None, None
    free = np.array(sorted({j for c in chosen for j in c.active}), dtype=int)
    offset = theta0 - theta
    cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)  # span by span
    nyquist = 0.5 / pred.dt

    def refit(band):
        """The final model refitted in ``band``: (its estimate of ``free``, each block's share of
        that estimate's error [B, f], the normal equations there, the model the selection ended with)."""
        rows_b = Rows(pred.t, pred.mask, pred.dt, band)
        residual_b = residual_under(pred, rows_b, theta).rows  # the final residual's rows in this band
        sigma_c, kappa, row_w = noise_of(rows_b, residual_b, robust=True)
        nrm_b = normal_equations(rows_b, residual_b, cols, 1.0 / (sigma_c**2 * kappa), row_w, blocks_of=nrm)
        _, inv_b, s_b = block_scores(nrm_b, free, offset)
        # the selection goes on from the final model: it may take an effect beside it there, never drop one
        selected, _, _ = select(nrm_b, offset, math.log(max(int(rows_b.keep.sum()) * 6, 2)), start=chosen)
        while True:  # an implausible value it took says the band's model is wrong: dropped as the judging does
            f2 = np.array(sorted({j for c in selected for j in c.active}), dtype=int)
            x, _, _ = solve(*nrm_b.total(), f2, offset)
            theta_b = theta0.copy()
            theta_b[f2] = theta[f2] + x
            bad = [c for c in selected[len(chosen) :] if judge(c.cand.id, theta_b[list(c.cand.idx)], grade)]
            if not bad:
                break
            selected = [c for c in selected if c not in bad]
        return theta_b[free], s_b @ inv_b, nrm_b, selected

    neighbours = [rows_of.bandwidth_hz * fac for fac in BAND_NEIGHBOURS]
    neighbours = [band for band in neighbours if band < 0.8 * nyquist]
    if not neighbours:
        return None, None
    # the reference is the same refit in the measured band: what the fit did beyond it (the parameters
    # fitted beside the findings, which the refits hold at their start values) is no band's doing
    est0, share0, nrm0, _ = refit(rows_of.bandwidth_hz)
    sys_cov = np.zeros((free.size, free.size))
    bands = []
    for band in neighbours:
        est_b, share_b, nrm_b, selected = refit(band)
        if share_b.shape[0] == share0.shape[0]:
            noise = np.abs(np.diag(long_run_meat(share_b - share0)))
        else:  # a gap that holds a block in one band only: Hausman's difference, from the same estimator
            variances = [np.diag(honest(*covariance(n, free, offset)[1:])) for n in (nrm_b, nrm0)]
            noise = np.abs(variances[0] - variances[1])
        part = systematic_shift(est_b - est0, noise)
        sys_cov += np.outer(part, part)
        bands.append({"bandwidth_hz": float(band), "selected": sorted(ch.cand.key for ch in selected)})
    return sys_cov / len(bands), bands


def systematic_shift(shift, noise) -> np.ndarray:
    """The part of a shift between two fits that is systematic, per component: ``shift`` scaled to
    ``sqrt(shift^2 - noise)`` where ``shift^2`` exceeds :func:`shift_chi2` of the number of
    components times ``noise`` (the variance of the shift's noise), 0 elsewhere.

    ``shift^2 - noise`` alone is unbiased but no evidence: for a shift of noise only it is positive
    a third of the time, and adds about half the noise variance on average; where the neighbouring
    band says much less than the measured one that is many times the estimate's own variance (the
    arms of development-range flights: the shift's noise up to fifty times their errors, seed 0).
    Beyond chance at the family-wise level it is the systematic part: a shift of noise only in one
    component then adds 0.075 times its variance on average. The level is shared among the
    components: at :data:`SHIFT_CHI2` each, a record of fifteen parameters would draw a systematic
    part from noise alone once in seven (``1 - 0.99^15``), and where the shift's noise is many
    times the estimate's error that part swamps it (a development-range flight, seed 99, over 16
    noise draws: a reference delay measured to 0.29 us scattered by 0.24 us, and one draw added
    3.9 us, a shift of 3.0 times its noise of 1.38 us)."""
    shift, noise = np.asarray(shift, dtype=float), np.asarray(noise, dtype=float)
    level = shift_chi2(shift.size)
    excess = np.where(shift**2 > level * noise, shift**2 - noise, 0.0)
    c = np.sqrt(np.divide(excess, shift**2, out=np.zeros_like(excess), where=shift**2 > 0))
    return c * shift


def error_budget(
    pred: Predictor,
    rows_of: Rows,
    nrm: Normal,
    theta,
    chosen,
    theta0,
    grade,
    parts: Parts | None = None,
    aliases=None,
    hidden=None,
) -> ErrorBudget:
    """The budget of the model ``chosen`` at the estimate ``theta`` with normal equations ``nrm``;
    ``parts``: :func:`parts_scatter` of this very state when the judging already formed it;
    ``aliases``, ``hidden``: the [free, free] parts of resolved aliases and of hidden parameters
    (:mod:`.aliases`), if any."""
    free = np.array(sorted({j for c in chosen for j in c.active}), dtype=int)
    if parts is None:
        parts = parts_scatter(pred, nrm, free, theta0 - theta)
    band, bands = band_part(pred, rows_of, nrm, theta, chosen, theta0, grade)
    return ErrorBudget(free, parts, aliases, hidden, parts.walk, band, bands)
