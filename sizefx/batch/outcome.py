"""What a batch's records are and what became of them: the job each record is
(:class:`BatchJob`), its manifest entry (:class:`RecordOutcome`) and the batch's result with the
report, the spread of the headline figures, the calibrations combined and the throughput
(:class:`BatchResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from statistics import fmean, stdev

from ..runs.figures import table_figures
from .fleet import combine_arms, recurring_findings

__all__ = ["BatchJob", "RecordOutcome", "BatchResult"]


def counted(n: int, noun: str) -> str:
    """``1 record``, ``2 records``: a count with its noun in the right number."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


@dataclass(frozen=True)
class BatchJob:
    """One record's work: the stage's config (built by the caller from the stage's own options, with
    this record's input and outputs), and what the manifest needs to judge a previous run of it."""

    stage: str
    input: str  #: the record, resolved
    name: str  #: its outputs' name in the batch folder
    config: object  #: the stage's config (``sizefx.navigate.NavigateConfig``, ...)
    options: dict  #: the stage options (canonical, :func:`~.manifest.canonical_options`)
    outputs: dict  #: option -> path of every file or folder the stage writes
    summary_path: str | None = None  #: where the batch writes ``result.to_json()`` (stages with no JSON of their own)
    previous: dict | None = None  #: this record's entry in the folder's manifest, if any
    redo: bool = False
    #: other files this record's run reads, option -> path (compare's B and reference, a chain's lever
    #: arms): hashed into the manifest like the input, so that a change to one runs the record again
    paired: dict = field(default_factory=dict)
    #: path -> SHA-256 of the input and paired files whose stat the folder's stat cache knows (set by
    #: the batch): not hashed again
    known: dict = field(default_factory=dict)


@dataclass
class RecordOutcome:
    """What became of one record: its manifest entry."""

    entry: dict
    reused: bool = False
    #: path -> (signature or None, sha256) of the files the worker hashed, for the folder's stat cache
    digests: dict = field(default_factory=dict)

    @property
    def status(self) -> str:
        return self.entry["status"]


@dataclass
class BatchResult:
    """Every record's outcome (in input order) and the manifest's path."""

    stage: str
    outcomes: list = field(default_factory=list)
    manifest: str = ""
    wall_s: float = 0.0
    workers: int = 1
    fleet_plot: str | None = None  #: with plots: the headline figures across the records

    def counts(self) -> dict:
        out = {"ok": 0, "refused": 0, "failed": 0, "skipped": 0}
        for o in self.outcomes:
            out["skipped" if o.reused else o.status] += 1
        return out

    @property
    def all_ok(self) -> bool:
        return all(o.status == "ok" for o in self.outcomes)

    def report(self) -> str:
        c = self.counts()
        lines = [
            f"batch {self.stage}: {counted(len(self.outcomes), 'record')} in {self.wall_s:.1f} s with "
            f"{counted(self.workers, 'worker')}: {c['ok']} ok, {c['skipped']} unchanged (skipped), {c['refused']} refused, "
            f"{c['failed']} failed; manifest -> {self.manifest}"
        ]
        table = {o.entry["name"]: table_figures(self.stage, o.entry["headline"]) for o in self.outcomes}
        for o in self.outcomes:
            e = o.entry
            figures = ", ".join(f"{k} {_short(v)}" for k, v in table[e["name"]].items())
            state = "unchanged" if o.reused else e["status"]
            lines.append(
                f"  {e['name']}: {state}, {e['duration_s']:.1f} s, {e['peak_memory_mib']:.0f} MiB"
                + (f"; {figures}" if figures and e["status"] == "ok" else "")
                + (f"; {e['reason']}" if e.get("reason") else "")
            )
        keys = dict.fromkeys(k for o in self.outcomes for k in table[o.entry["name"]])
        for k in keys:  # the campaign's spread of each numeric figure
            values = [
                table[o.entry["name"]][k]
                for o in self.outcomes
                if o.status == "ok" and isinstance(table[o.entry["name"]].get(k), (int, float))
            ]
            if len(values) > 1:
                lines.append(
                    f"  {k} across {counted(len(values), 'record')}: mean {fmean(values):.4g}, "
                    f"std {stdev(values):.3g}, min {min(values):.4g}, max {max(values):.4g}"
                )
        if self.stage == "diagnose":
            ok = sum(o.status == "ok" for o in self.outcomes)
            recurring = recurring_findings([o.entry for o in self.outcomes])
            lines.append(
                f"  findings in more than one of {ok} records: "
                + (", ".join(f"{f} ({n})" for f, n in recurring) or "none")
            )
        combined = self.combined()
        if combined:
            import numpy as np

            mm = np.array(combined["arms_m"]) * 1e3
            lines.append(
                f"  arms of {combined['runs']} runs combined (inverse-variance) [mm], +- sigma, chi2/dof across runs:"
            )
            for i, a in enumerate("xyz"):
                lines.append(
                    f"    r_{a}  "
                    + "  ".join(
                        f"{mm[i][j]:8.4f} +- {combined['sigma_m'][i][j] * 1e3:.4f} ({combined['chi2_dof'][i][j]:.2f})"
                        for j in range(3)
                    )
                )
            lines.append(
                "  runs that disagree with the others (|z| > 3.3): "
                + (", ".join(f"{name} ({z:.1f} sigma)" for name, z in combined["disagree"]) or "none")
            )
        pace = self.throughput()
        if pace["records_run"]:
            busy = list(pace["busy"].values())
            lines.append(
                f"  {counted(pace['records_run'], 'record')} run: {pace['records_per_s']:.3g} records/s, "
                f"{pace['samples_per_s']:.3g} samples/s"
                + (
                    f"; {counted(len(busy), 'worker')} busy {100 * min(busy):.0f}-{100 * max(busy):.0f} % of the wall time "
                    f"(mean {100 * pace['busy_mean']:.0f} %)"
                    if busy
                    else ""
                )
            )
            phases, total = pace["phases_s"], pace["records_s"]
            if total > 0 and phases.get("stage"):
                own = [k for k in phases if k not in ("hash", "stage", "outputs")]
                lines.append(
                    f"  the records' {total:.3g} s: stage {100 * phases['stage'] / total:.0f} %"
                    + (f" ({', '.join(f'{k} {100 * phases[k] / total:.0f}' for k in own)})" if own else "")
                    + f", outputs {100 * phases.get('outputs', 0.0) / total:.0f} %"
                    + f"; hashing {100 * phases.get('hash', 0.0) / total:.0f} % (beside the stage where a core is free)"
                )
        if self.fleet_plot:
            lines.append(f"  figures across the records -> {self.fleet_plot}")
        return "\n".join(lines)

    def throughput(self) -> dict:
        """This run's pace, over the records it ran (not those skipped): how many, records and IMU
        samples per second of the batch's wall time, each worker's busy fraction (the seconds it spent
        on records over the wall time: where more workers stop helping, it falls) and their mean,
        the records' durations summed (``records_s``) and their phases summed [s] (``hash`` runs beside
        the stage where a core is free, after it in workers that fill the cores; the stage's own phases,
        where it keeps them, add up to ``stage``)."""
        run = [o.entry for o in self.outcomes if not o.reused]
        wall = self.wall_s if self.wall_s > 0 else float("nan")
        busy: dict[str, float] = {}
        phases: dict[str, float] = {}
        for e in run:
            if e.get("worker"):
                busy[e["worker"]] = busy.get(e["worker"], 0.0) + e["duration_s"] / wall
            for k, v in (e.get("phases_s") or {}).items():
                phases[k] = phases.get(k, 0.0) + v
        samples = sum(e.get("samples") or 0 for e in run if e["status"] == "ok")
        return {
            "records_run": len(run),
            "wall_s": self.wall_s,
            "records_per_s": len(run) / wall,
            "samples_per_s": samples / wall,
            "busy": busy,
            "busy_mean": fmean(busy.values()) if busy else float("nan"),
            "records_s": sum(e["duration_s"] for e in run),
            "phases_s": phases,
        }

    def combined(self) -> dict | None:
        """Calibrations across the runs combined, with the consistency test (:func:`.fleet.combine_arms`)."""
        return combine_arms([o.entry for o in self.outcomes]) if self.stage == "calibrate" else None

    def to_json(self) -> dict:
        return {
            "stage": self.stage,
            "manifest": self.manifest,
            "wall_s": self.wall_s,
            "workers": self.workers,
            "counts": self.counts(),
            "throughput": self.throughput(),
            "records": [o.entry for o in self.outcomes],
            **({"combined_arms": self.combined()} if self.stage == "calibrate" else {}),
        }


def _short(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)
