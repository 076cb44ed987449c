"""What ``sizefx compare`` says: the lines it prints and its ``sizefx/comparison/1`` JSON document.

:func:`format_comparison` writes one comparison's figures with their units,
:func:`format_report` those of a whole run; :func:`to_json` builds the document and checks it
against ``data-schemas/comparison-1.json`` (:func:`sizefx.io.schema.check_document`). The
figures themselves come from :func:`sizefx.compare.metrics.compare`; nothing is computed here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import __version__
from ..io.schema import check_document
from .geodesy import MIN_GROUND_SPEED_MPS

if TYPE_CHECKING:
    from .metrics import Comparison

__all__ = ["COMPARISON_SCHEMA", "format_comparison", "format_report", "to_json"]

COMPARISON_SCHEMA = "sizefx/comparison/1"

# --------------------------------------------------------------------------- text


def _fmt(x, spec: str = ".4g") -> str:
    return "n/a" if x is None else format(x, spec)


def format_comparison(result: Comparison) -> str:
    """Several lines of text: the figures of one comparison with their units."""
    s = result.summary
    one, two = result.pair
    h = s["horizontal_m"]
    drift = s["drift_nmi_per_h"]
    lines = [
        (
            f"{s['label']}: {s['a']} minus {s['b']} on {s['samples']} samples of {one}, "
            f"t = {s['time_start_s']:.3f} .. {s['time_end_s']:.3f} s ({s['elapsed_s'] / 60.0:.2f} min)"
        ),
        (
            f"  horizontal distance: final {_fmt(h['final'])} m, max {_fmt(h['max'])} m at t = "
            f"{h['time_of_max_s']:.3f} s, RMS {_fmt(h['rms'])} m"
        ),
        f"  drift: final {_fmt(drift['final'])} nmi/h, max {_fmt(drift['max'])} nmi/h (distance / elapsed time)",
    ]
    for key, what in (
        ("along_track_m", f"along track ({one} ahead +)"),
        ("cross_track_m", f"cross track ({one} right of {two}'s track +)"),
    ):
        st = s[key]
        lines.append(f"  {what}: final {_fmt(st['final'])} m, max |.| {_fmt(st['max_abs'])} m, RMS {_fmt(st['rms'])} m")
    if s["track_defined_samples"] < s["samples"]:
        lines.append(
            f"    (n/a: along/cross track undefined at {s['samples'] - s['track_defined_samples']} samples, "
            f"{two} slower than {MIN_GROUND_SPEED_MPS:g} m/s)"
        )
    st = s["height_m"]
    lines.append(f"  height: final {_fmt(st['final'])} m, RMS {_fmt(st['rms'])} m, max |.| {_fmt(st['max_abs'])} m")
    v = s["velocity_mps"]
    lines.append(
        "  velocity N / E / D: final "
        + " / ".join(_fmt(v[k]["final"]) for k in ("north", "east", "down"))
        + " m/s, RMS "
        + " / ".join(_fmt(v[k]["rms"]) for k in ("north", "east", "down"))
        + " m/s"
    )
    lines.append(
        f"  ground speed: final {_fmt(v['ground_speed']['final'])} m/s, RMS {_fmt(v['ground_speed']['rms'])} m/s"
    )
    att = s["attitude_deg"]
    if att is not None:
        names = ("roll", "pitch", "heading")
        lines.append(
            "  attitude roll / pitch / heading: final "
            + " / ".join(_fmt(att[k]["final"]) for k in names)
            + " deg, RMS "
            + " / ".join(_fmt(att[k]["rms"]) for k in names)
            + " deg, max |.| "
            + " / ".join(_fmt(att[k]["max_abs"]) for k in names)
            + " deg"
        )
        tot = att["total"]
        lines.append(
            f"  attitude rotation angle: final {_fmt(tot['final'])} deg, RMS {_fmt(tot['rms'])} deg, "
            f"max {_fmt(tot['max'])} deg"
        )
    lines += [f"  note: {n}" for n in s["notes"]]
    return "\n".join(lines)


def format_report(result) -> str:
    """All comparisons of a run, and with a reference the divergence in one line.

    ``result``: what :func:`sizefx.compare.run` returns (its ``comparisons`` and ``inputs``).
    """
    blocks = [format_comparison(c) for c in result.comparisons]
    if result.inputs.get("reference"):
        by = {c.label: c.summary["horizontal_m"]["final"] for c in result.comparisons}
        blocks.append(
            f"final horizontal distance: A from REF {_fmt(by['A vs REF'])} m, B from REF "
            f"{_fmt(by['B vs REF'])} m; A and B diverge by {_fmt(by['A vs B'])} m"
        )
    return "\n".join(blocks)


# --------------------------------------------------------------------------- JSON


def to_json(comparisons, inputs: dict, plots=()) -> dict:
    """The ``sizefx/comparison/1`` document (checked against ``data-schemas/comparison-1.json``)."""
    doc = {
        "schema": COMPARISON_SCHEMA,
        "sizefx_version": __version__,
        "inputs": {
            "a": str(inputs["a"]),
            "b": str(inputs["b"]),
            "reference": None if inputs.get("reference") is None else str(inputs["reference"]),
        },
        "units": {
            "distance": "m",
            "time": "s",
            "drift": "nmi/h (1852 m)",
            "velocity": "m/s",
            "angle": "deg",
            "sign": "each comparison is its a minus its b; along track positive when a is ahead, cross track "
            "positive when a is right of b's track",
        },
        "min_ground_speed_mps": MIN_GROUND_SPEED_MPS,
        "comparisons": [c.summary for c in comparisons],
        "plots": [str(p) for p in plots],
    }
    _check_document(doc)
    return doc


def _check_document(doc: dict):
    """Our writer against our contract (a bug if it fails)."""
    check_document(doc, COMPARISON_SCHEMA)
