"""The ``compare`` stage: ``sizefx compare A B [--reference REF]``.

The seed paper's question is how far a solution navigated with the size effect
compensated and one navigated without it diverge, and how far each is from the
truth. This stage answers it for any two tracks, one concern per module:

- :mod:`~sizefx.compare.read`: a ``sizefx/navigation/1`` file (``sizefx navigate -o``) or a
  ``sizefx/telemetry/1`` file's ``/reference`` becomes a :class:`Track` in SI units;
- :mod:`~sizefx.compare.geodesy`: the chord on WGS-84, its along/cross-track parts, velocity
  from positions;
- :mod:`~sizefx.compare.metrics`: :func:`compare`, A against B on A's time stamps, every
  difference A minus B, and its statistics;
- :mod:`~sizefx.compare.report`: the text and the ``sizefx/comparison/1`` JSON document;
- :mod:`~sizefx.compare.plots`: the figures (matplotlib imported only when asked for);
- here: the stage shape of :mod:`sizefx.stage`, :class:`CompareConfig` in,
  :class:`CompareResult` out, :func:`run` between them.

A Python caller makes the same call as the command line::

    from sizefx.compare import CompareConfig, run
    result = run(CompareConfig("compensated.h5", "plain.h5", reference="flight.h5", json_path="cmp.json"))
    print(result.report())

The modules import downwards only (read, geodesy <- metrics <- report, plots <- this one).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..configs.compare import CompareConfig
from ..io.documents import write_json
from ..stage import preflight
from .geodesy import (
    MIN_GROUND_SPEED_MPS,
    along_cross_track_m,
    horizontal_offset_m,
    surface_ecef_m,
    velocity_from_position,
)
from .metrics import Comparison, compare
from .plots import plot_names, pyplot, write_plots
from .read import NAVIGATION_SCHEMA, Track, read_track
from .report import COMPARISON_SCHEMA, format_comparison, format_report, to_json

__all__ = [
    "COMPARISON_SCHEMA",
    "MIN_GROUND_SPEED_MPS",
    "NAVIGATION_SCHEMA",
    "CompareConfig",
    "CompareResult",
    "Comparison",
    "Track",
    "along_cross_track_m",
    "compare",
    "format_comparison",
    "format_report",
    "horizontal_offset_m",
    "read_track",
    "run",
    "surface_ecef_m",
    "to_json",
    "velocity_from_position",
]


@dataclass
class CompareResult:
    """What :func:`run` found and wrote."""

    config: CompareConfig
    inputs: dict  #: {"a": path, "b": path, "reference": path or None}, as written into the JSON
    comparisons: list  #: [Comparison]: A vs B, or A vs REF, B vs REF, A vs B
    document: dict  #: the sizefx/comparison/1 document
    tracks: dict  #: {"A": Track, "B": Track, "REF": Track}
    plots: list = field(default_factory=list)  #: [Path] the figures written

    def report(self) -> str:
        """The lines ``sizefx compare`` prints: the figures, then each file written."""
        lines = [format_report(self)]
        if self.config.json_path:
            lines.append(f"comparison -> {self.config.json_path}")
        lines += [f"figure -> {png}" for png in self.plots]
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The ``sizefx/comparison/1`` document (what ``--json`` writes)."""
        return self.document


def run(config: CompareConfig, *, progress=None) -> CompareResult:
    """Entry point of ``sizefx compare``: check, read, compare, write what was asked.

    Without ``config.reference``: A vs B. With it: A vs REF, B vs REF and A vs B (how far
    the two solutions diverge, and how far each is from the truth; the along/cross-track
    split of A vs B follows the reference's motion). Before any work: the inputs exist,
    the outputs are new (or ``force``), writable and distinct from each other and from every
    input (:func:`sizefx.stage.preflight`), matplotlib is there when figures are asked for.
    ``progress(done, total)`` is called after each file read, after the comparisons and
    after the outputs.
    """
    preflight(
        inputs=config.inputs(), outputs=config.outputs(), force=config.force, folders={"--plots": config.plots_dir}
    )
    if config.plots_dir:
        pyplot()  # fail before the work when matplotlib is missing
    with_ref = config.reference is not None
    files = {"A": config.a, "B": config.b, **({"REF": config.reference} if with_ref else {})}
    total = len(files) + 2  # each file, the comparisons, the outputs

    def tick(done: int):
        if progress is not None:
            progress(done, total)

    tracks = {}
    for k, (key, path) in enumerate(files.items(), start=1):
        tracks[key] = read_track(path)
        tick(k)
    if with_ref:
        comparisons = [
            compare(tracks["A"], tracks["REF"], "A vs REF"),
            compare(tracks["B"], tracks["REF"], "B vs REF"),
            compare(tracks["A"], tracks["B"], "A vs B", track=tracks["REF"]),
        ]
    else:
        comparisons = [compare(tracks["A"], tracks["B"], "A vs B")]
    tick(total - 1)
    pngs = [Path(config.plots_dir) / name for name in plot_names(comparisons)] if config.plots_dir else []
    ins = {"a": str(config.a), "b": str(config.b), "reference": str(config.reference) if with_ref else None}
    document = to_json(comparisons, ins, pngs)
    result = CompareResult(config, ins, comparisons, document, tracks)
    if config.plots_dir:
        Path(config.plots_dir).mkdir(exist_ok=True)
        result.plots = write_plots(comparisons, tracks, config.plots_dir)
    if config.json_path:
        write_json(config.json_path, document, inputs=list(files.values()), force=config.force, allow_nan=False)
    tick(total)
    return result
