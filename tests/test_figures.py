"""No figure without a source: the measured figures in README.md and docs/ against the result files.

``docs/figures.toml`` lists each quoted figure as the text it stands in on its page, with
placeholders for the numbers, and the result file they come from (``benchmarks/results/*.json``,
written by ``python benchmarks/SCRIPT.py --record``, or ``docs/paper/results.json``, written by
``sizefx paper all``). A placeholder is Python's ``format`` field with a path into the JSON:

    "takes {figures.end_to_end_warm.wall_s:.1f} s end to end"

- ``a.b.0.c``: keys and list indices, from the file's top level;
- ``/1e6``, ``*1e3`` at the end of the path: the value scaled (``{figures.rate/1e6:.1f} M``);
- ``|min``, ``|max``: the least or largest of a list (or of an object's values); ``|abs``: the
  value, or each of them, made positive (``{x|abs|max}``); ``|flat``: a nested list as one list
  (``{m|flat|abs|max}``: the largest magnitude in a matrix);
- the format spec ``_`` groups thousands with a space (``{x:_.0f}``: ``12 001``); an exponent is
  written without padding (``{x:.1e}``: ``8.3e-9``), a percentage with a space (``{x:.0%}``: ``6 %``);
- the conversion ``!m`` writes a minus sign as U+2212 (``{x!m:+.2f}``: ``−0.01``);
- ``{command}``, ``{date}``: the run's own command line and date.

Checked here, without running anything: every text, filled from its file, occurs in its page
(wrapped anywhere between its words); every result file records a clean checkout; a speed figure
measured on a busy machine (the file's ``machine.quiet`` false) stands beside the words "under
load" and never beside "quiet"; and, the other way round, every number with a unit of time,
memory, throughput or accuracy in the sections that ``docs/figures.toml`` scopes is covered by a registered
text (or a ``[[given]]`` text: an input such as a record's length, not a measurement), so a new
figure without a source fails here.
"""

from __future__ import annotations

import json
import re
import string
import tomllib
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REGISTRY = ROOT / "docs" / "figures.toml"

#: A number followed by a unit of time, memory, throughput or accuracy (length, position,
#: acceleration, angle, angular rate, ratio, standard errors): what the reverse check looks for. A
#: range (``0.2–0.4 %``, ``1052 ± 70 arcsec``) is one figure.
FIGURE = re.compile(
    r"(?<![\w.])[−-]?\d[\d.]*(?:[  ]\d{3})*(?:\s*(?:[–-]|±|to)\s*[−-]?\d[\d.]*)?\s*"
    r"(?:s|ms|µs|min|MiB|GiB|KiB|MB|GB|M samples/s|samples/s"
    r"|µm|mm|cm|km|m/s²|m/s|m|µg/√Hz|µg/√h|µg|mg|ppm|arcsec|″|deg/h/g|deg/h|°/h|deg/√h|deg/s²|deg/s|nmi/h"
    r"|mrad|µrad|deg|°|%|σ)(?![\w/])"
)

#: Walk-throughs whose shown outputs (```text blocks) a test compares with what the commands print:
#: (start marker, end marker), each with its test.
WALKTHROUGHS = (
    ("<!-- own-recording:start", "<!-- own-recording:end -->"),  # tests/test_own_recording.py
)


class _Minus:
    """A number that formats its minus sign as U+2212."""

    def __init__(self, value):
        self.value = value

    def __format__(self, spec):
        return format(self.value, spec).replace("-", "−")


def _flatten(values):
    for v in values:
        if isinstance(v, list):
            yield from _flatten(v)
        else:
            yield v


class FigureFormatter(string.Formatter):
    """``str.format`` whose fields are paths into a JSON document (the grammar above)."""

    def __init__(self, doc: dict):
        super().__init__()
        self.doc = doc

    def get_field(self, field_name, args, kwargs):
        path, *reducers = field_name.split("|")
        scale = re.search(r"([*/])([0-9.]+(?:e[+-]?\d+)?)$", path)
        if scale:
            path = path[: scale.start()]
        value = self.doc
        for key in path.split("."):
            try:
                value = value[int(key)] if isinstance(value, list) else value[key]
            except (KeyError, IndexError, ValueError, TypeError):
                raise KeyError(f"{field_name}: no {key!r} in the result file") from None
        if scale:
            factor = float(scale.group(2))
            value = value * factor if scale.group(1) == "*" else value / factor
        for reducer in reducers:
            values = list(value.values()) if isinstance(value, dict) else value
            if reducer == "flat":
                value = list(_flatten(values))
            elif reducer == "abs":
                value = [abs(v) for v in values] if isinstance(values, list) else abs(values)
            else:
                value = {"min": min, "max": max}[reducer](values)
        return value, field_name

    def convert_field(self, value, conversion):
        return _Minus(value) if conversion == "m" else super().convert_field(value, conversion)

    def format_field(self, value, format_spec):
        text = format(value, format_spec)
        if "_" in format_spec:
            text = text.replace("_", " ")
        if format_spec.endswith("%"):
            text = text[:-1] + " %"  # the pages' spacing: 6 %
        return re.sub(r"e([+-])0(\d)", r"e\1\2", text).replace("e+", "e")  # 8.3e-09 as 8.3e-9


@cache
def registry() -> dict:
    return tomllib.loads(REGISTRY.read_text())


@cache
def source(path: str) -> dict:
    return json.loads((ROOT / path).read_text())


@cache
def page(path: str) -> str:
    return (ROOT / path).read_text()


def filled(entry: dict) -> str:
    return FigureFormatter(source(entry["source"])).format(entry["text"])


def pattern(phrase: str) -> re.Pattern:
    """``phrase`` as it may stand in a page: wrapped anywhere between its words."""
    return re.compile(r"\s+".join(re.escape(word) for word in phrase.split()))


def entry_id(entry: dict) -> str:
    return f"{entry['page']}: {entry['text'][:60]}"


FIGURES = registry()["figure"]
SOURCES = sorted({e["source"] for e in FIGURES})


@pytest.mark.parametrize("entry", FIGURES, ids=entry_id)
def test_each_figure_reads_as_its_result_file_says(entry):
    text = filled(entry)
    assert pattern(text).search(page(entry["page"])), (
        f"{entry['page']} should read {text!r} ({entry['source']}); re-measure with the file's command "
        f"or correct the page"
    )


@pytest.mark.parametrize("path", [s for s in SOURCES if s.startswith("benchmarks/results/")])
def test_each_result_file_records_its_run_from_a_clean_checkout(path):
    doc = source(path)
    for key in ("command", "date", "commit", "machine", "figures"):
        assert key in doc, f"{path} lacks {key!r}: write it with the script's --record"
    assert doc["commit"]["dirty"] is False, f"{path} was measured on a checkout with uncommitted changes"
    assert doc["command"].startswith(f"python {doc['script']}"), doc["command"]
    load = doc["machine"]["load_average_1min"]
    assert {"start", "end"} <= set(load), load


#: Each explanation page ends with the result files its figures come from, between these markers,
#: written by ``python tests/test_figures.py --rewrite`` from the registry and the files themselves.
SOURCES_START = "<!-- figure sources: written by `python tests/test_figures.py --rewrite` from docs/figures.toml -->"
SOURCES_END = "<!-- /figure sources -->"
#: Pages whose figures are listed so (README.md and examples/README.md cite each command inline).
SOURCE_LISTED_PAGES = sorted({e["page"] for e in FIGURES if e["page"].startswith("docs/")})


def sources_section(page_path: str) -> str:
    """The markdown that ends ``page_path``: each result file its registered figures come from, in the
    order the registry first names them, with the command, date, commit and machine of its run."""
    from os.path import relpath

    paths = list(dict.fromkeys(e["source"] for e in FIGURES if e["page"] == page_path))
    commands = registry().get("commands", {})
    lines = [
        SOURCES_START,
        "## Where the figures come from",
        "",
        "Every measured figure on this page is read from one of these result files "
        "(`tests/test_figures.py` checks each against its file):",
        "",
    ]
    for path in paths:
        link = relpath(ROOT / path, (ROOT / page_path).parent)
        doc = source(path)
        if "command" in doc:
            machine = doc["machine"]
            where = f"{machine['cores']} cores" + ("" if machine.get("quiet", True) else ", under load")
            told = f"`{doc['command']}`, {doc['date'][:10]}, commit {doc['commit']['describe']}, {where}"
        else:
            told = f"`{commands[path]}` (a seeded simulation: the same figures on any machine)"
        lines.append(f"- [`{path}`]({link}): {told}")
    return "\n".join([*lines, SOURCES_END]) + "\n"


def _with_sources(text: str, page_path: str) -> str:
    """``text`` with its sources section replaced by (or, if it has none, ended with) today's."""
    section = sources_section(page_path)
    if SOURCES_START in text:
        head, _, rest = text.partition(SOURCES_START)
        _, _, tail = rest.partition(SOURCES_END + "\n")
        return head + section + tail
    return text.rstrip("\n") + "\n\n" + section


@pytest.mark.parametrize("path", SOURCE_LISTED_PAGES)
def test_each_page_lists_the_result_files_of_its_figures(path):
    text = page(path)
    assert _with_sources(text, path) == text, (
        f"{path}: its closing list of result files is not what docs/figures.toml and the files say; "
        f"run `python tests/test_figures.py --rewrite`"
    )


def paragraphs_around(text: str, at: int) -> str:
    """The paragraph (lines up to a blank line) holding position ``at``, and the one before it."""
    start = text.rfind("\n\n", 0, at)
    start = text.rfind("\n\n", 0, start) if start > 0 else 0
    end = text.find("\n\n", at)
    return text[max(start, 0) : end if end >= 0 else len(text)]


@pytest.mark.parametrize("entry", [e for e in FIGURES if e["kind"] == "speed"], ids=entry_id)
def test_a_speed_figure_from_a_busy_machine_says_so(entry):
    doc = source(entry["source"])
    text, where = page(entry["page"]), filled(entry)
    found = pattern(where).search(text)
    if not found or doc.get("machine", {}).get("quiet", True):
        return  # the first test reports a missing figure; a quiet run needs no words
    around = paragraphs_around(text, found.start())
    assert "under load" in around, f"{entry['page']}: {where!r} was measured under load and should say so"
    assert not re.search(r"(?<!--)\bquiet\b", around), (  # the word, not the option --quiet
        f"{entry['page']}: {where!r} was measured under load, not on quiet cores"
    )


def sections(text: str, titles: list[str]) -> list[tuple[int, int]]:
    """Spans of the sections (``##`` and deeper) with these titles, each up to the next heading of
    its level or above."""
    spans = []
    for title in titles:
        m = re.search(rf"^(#+) {re.escape(title)}\s*$", text, re.M)
        assert m, f"no section {title!r}"
        level = len(m.group(1))
        nxt = re.compile(rf"^#{{1,{level}}} ", re.M).search(text, m.end())
        spans.append((m.end(), nxt.start() if nxt else len(text)))
    return spans


@pytest.mark.parametrize("scope", registry()["scope"], ids=lambda s: s["page"])
def test_every_measured_figure_in_a_scoped_section_has_a_source(scope):
    text = page(scope["page"])
    covered = []
    for entry in FIGURES + [dict(g, source=None) for g in registry().get("given", [])]:
        if entry["page"] != scope["page"]:
            continue
        phrase = filled(entry) if entry["source"] else entry["text"]
        covered += [(m.start(), m.end()) for m in pattern(phrase).finditer(text)]
    # a command's printed output shown in a walk-through that a test runs and compares (README's
    # "Your own recording": tests/test_own_recording.py) is the code's output, not a measured figure
    for start, end in WALKTHROUGHS:
        if start in text and end in text:
            a = text.index(start)
            section = (a, text.index(end, a))
            covered += [
                (m.start(), m.end()) for m in re.compile(r"^```text\n.*?^```", re.S | re.M).finditer(text, *section)
            ]
    spans = sections(text, scope["sections"]) if "sections" in scope else [(0, len(text))]
    orphans = [
        m.group(0)
        for a, b in spans
        for m in FIGURE.finditer(text, a, b)
        if not any(s <= m.start() and m.end() <= e for s, e in covered)
    ]
    assert not orphans, (
        f"{scope['page']}: figures without a source: {orphans}; register each in docs/figures.toml "
        f"with its result file (or as [[given]] when it is an input, not a measurement)"
    )


def test_every_page_is_scoped_and_every_given_says_why():
    pages = {"README.md", *(str(p.relative_to(ROOT)) for d in ("docs", "examples") for p in (ROOT / d).glob("*.md"))}
    scoped = {s["page"] for s in registry()["scope"]}
    assert pages <= scoped, f"pages no scope covers: {sorted(pages - scoped)}; add a [[scope]] for each"
    for given in registry().get("given", []):
        assert given.get("why"), f"{given['page']}: [[given]] {given['text']!r} needs a `why`"
        assert pattern(given["text"]).search(page(given["page"])), (
            f"{given['page']} no longer reads the [[given]] text {given['text']!r}; correct or remove it"
        )


def test_the_reverse_check_sees_accuracy_figures_as_well_as_timings():
    found = [
        m.group(0)
        for m in FIGURE.finditer(
            "took 2.5 s, 570 MiB; arms 0.028–0.032 mm, lag 1052 ± 70 arcsec, the delay −44 µs, 0.09 µg, "
            "14.85 deg/h, 0.6 σ, 10 %, 1.07 km, 0.62 m/s, 2.5 µg/√Hz, 20 deg/s; not CH4 or v2.5 or 3D"
        )
    ]
    assert found == [
        "2.5 s",
        "570 MiB",
        "0.028–0.032 mm",
        "1052 ± 70 arcsec",
        "−44 µs",
        "0.09 µg",
        "14.85 deg/h",
        "0.6 σ",
        "10 %",
        "1.07 km",
        "0.62 m/s",
        "2.5 µg/√Hz",
        "20 deg/s",
    ]


def test_the_formatter_reads_paths_scales_and_signs():
    f = FigureFormatter(
        {"a": {"b": [1.5, -0.0123]}, "r": 13_412_345.0, "n": 12001, "xs": [3, 1, 2], "m": [[1, -4], [3, 2]]}
    )
    assert f.format("{a.b.0:.1f}") == "1.5"
    assert f.format("{r/1e6:.1f} M") == "13.4 M"
    assert f.format("{a.b.1*1e3!m:+.1f}") == "−12.3"
    assert f.format("{n:_d}") == "12 001"
    assert f.format("{xs|min}–{xs|max} {a.b|abs|min}") == "1–3 0.0123"
    assert f.format("{m|flat|abs|max} {m|flat|min}") == "4 -4"
    assert f.format("{a.b.1:.1e} {r:.0e} {a.b.0:.0%}") == "-1.2e-2 1e7 150 %"
    with pytest.raises(KeyError, match="no 'c'"):
        f.format("{a.c}")


def rewrite(revision: str = "HEAD") -> list[str]:
    """Each registered text as its result file at ``revision`` filled it, replaced on its page by
    the text the file in the working tree fills (the line breaks kept where the words are as many),
    and each page's closing list of result files made anew. Returns the pages changed."""
    import subprocess

    changed = set()
    for entry in FIGURES:
        old_doc = subprocess.run(
            ["git", "-C", str(ROOT), "show", f"{revision}:{entry['source']}"], capture_output=True, text=True
        )
        if old_doc.returncode != 0:
            continue  # a new result file: nothing to replace
        try:
            old = FigureFormatter(json.loads(old_doc.stdout)).format(entry["text"])
        except KeyError:
            continue  # a new entry: the old file cannot fill it
        new = filled(entry)
        path = ROOT / entry["page"]
        text = path.read_text()
        found = pattern(old).search(text)
        if old == new or not found:
            continue
        gaps = re.findall(r"\s+", found.group(0))
        words = new.split()
        if len(words) == len(gaps) + 1:
            new = "".join(w + g for w, g in zip(words, gaps + [""]))
        path.write_text(text[: found.start()] + new + text[found.end() :])
        changed.add(entry["page"])
    for listed in SOURCE_LISTED_PAGES:
        path = ROOT / listed
        text = path.read_text()
        if _with_sources(text, listed) != text:
            path.write_text(_with_sources(text, listed))
            changed.add(listed)
    return sorted(changed)


if __name__ == "__main__":
    import sys

    # `python tests/test_figures.py`: every registered text as its result file fills it, and whether
    # its page reads so. `--rewrite [REV]`: after a re-measurement, put the new figures into the
    # pages where they read as the result files at REV (default HEAD) filled them.
    if sys.argv[1:2] == ["--rewrite"]:
        print("rewritten:", ", ".join(rewrite(*sys.argv[2:3])) or "nothing")
        sys.exit(0)
    for entry in FIGURES:
        try:
            text = filled(entry)
        except (KeyError, ValueError, TypeError, OSError) as e:
            print(f"ERROR {entry_id(entry)}: {e}")
            continue
        print(f"{'ok     ' if pattern(text).search(page(entry['page'])) else 'MISSING'} {entry['page']}: {text}")
