"""docs/reference/diagnosis-report.md: its two examples are what their commands print and write.

The page's ```sh block holds the commands; its first two ```text blocks what the two diagnoses
print (a line ``…`` stands for lines left out); its ```jsonc block the first one's ``report.json``
with ``//`` comments, ``…`` for what is left out. The long tier runs the commands as written in a
fresh folder and checks every shown line and every number of the excerpt, so that the reference
cannot drift from the code.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference" / "diagnosis-report.md"
#: The installed console script, as a user runs it.
SIZEFX = Path(sys.executable).with_name("sizefx")
#: A line of its own in a shown block: lines left out.
ELISION = "…"
#: Relative agreement of a number in the excerpt with the file: the page's figures are one run's,
#: and a float's last digits may differ on another machine's BLAS.
RTOL = 1e-6


def _blocks(text: str, kind: str) -> list:
    return re.findall(rf"^```{kind}\n(.*?)^```", text, flags=re.S | re.M)


def page_commands(text: str) -> list:
    """The argv lists of the page's ```sh block, continuations joined, comments dropped."""
    (block,) = _blocks(text, "sh")
    return [argv for line in block.replace("\\\n", " ").splitlines() if (argv := shlex.split(line, comments=True))]


def shown_lines(block: str) -> list:
    """A ```text block's lines, whitespace normalised, without blank and elision lines."""
    return [n for n in (" ".join(line.split()) for line in block.splitlines()) if n and n != ELISION]


def excerpt(text: str):
    """The ```jsonc block parsed: comments dropped, ``…`` elisions as empty or null."""
    (block,) = _blocks(text, "jsonc")
    lines = [re.sub(r"\s*//.*$", "", line) for line in block.splitlines()]
    kept = [
        line.replace("{…}", "{}").replace("[…]", "[]").replace(": …", ": null")
        for line in lines
        if line.strip() not in (ELISION, ELISION + ",")
    ]
    return json.loads(re.sub(r",(\s*[\]}])", r"\1", "\n".join(kept)))


#: Keys that name an element of a list of objects (the excerpt may leave elements out).
IDENTITY = ("id", "channel", "parameter", "effect", "split")


def mismatches(shown, written, path="") -> list:
    """Where the excerpt ``shown`` differs from the file ``written``: every number within
    :data:`RTOL`, every string equal; an element of a list of objects is found by its
    :data:`IDENTITY` keys, and a null or empty container (an elision) matches anything."""
    if shown is None or shown == {} or shown == []:
        return []
    if isinstance(shown, dict):
        if not isinstance(written, dict):
            return [f"{path}: an object in the page, {type(written).__name__} in the file"]
        out = []
        for key, value in shown.items():
            out += (
                mismatches(value, written[key], f"{path}/{key}")
                if key in written
                else [f"{path}/{key}: not in the file"]
            )
        return out
    if isinstance(shown, list):
        out = []
        for i, item in enumerate(shown):
            ids = {k: item[k] for k in IDENTITY if isinstance(item, dict) and k in item}
            if ids:
                match = [w for w in written if isinstance(w, dict) and all(w.get(k) == v for k, v in ids.items())]
                out += (
                    mismatches(item, match[0], f"{path}{ids}")
                    if len(match) == 1
                    else [f"{path}{ids}: {len(match)} in the file"]
                )
            else:
                out += (
                    mismatches(item, written[i], f"{path}/{i}")
                    if i < len(written)
                    else [f"{path}/{i}: not in the file"]
                )
        return out
    if isinstance(shown, bool) or isinstance(shown, str):
        return [] if shown == written else [f"{path}: {shown!r} in the page, {written!r} in the file"]
    return (
        []
        if np.isclose(shown, written, rtol=RTOL, atol=0.0)
        else [f"{path}: {shown!r} in the page, {written!r} in the file"]
    )


def test_the_page_gives_two_commands_two_outputs_and_an_excerpt():
    text = PAGE.read_text("utf-8")
    commands = page_commands(text)
    assert [argv[:2] for argv in commands] == [["sizefx", "simulate"], ["sizefx", "diagnose"]] * 2
    assert len(_blocks(text, "text")) >= 2 and all(shown_lines(b) for b in _blocks(text, "text")[:2])
    shown = excerpt(text)
    assert shown["schema"] == "sizefx/diagnosis/2" and shown["effects"]


def test_the_excerpt_check_finds_a_changed_number_and_passes_over_an_elision():
    written = {"a": [{"id": "x", "v": 1.0}, {"id": "y", "v": 2.0}], "b": {"c": 3.0}, "d": "s"}
    assert mismatches({"a": [{"id": "y", "v": 2.0}], "b": {}, "d": "s"}, written) == []
    assert mismatches({"a": [{"id": "y", "v": 2.1}]}, written) == ["/a{'id': 'y'}/v: 2.1 in the page, 2.0 in the file"]
    assert mismatches({"e": 1}, written) == ["/e: not in the file"]


# long tier: two simulations and two diagnoses (about 20 s); fast twins: the two tests above
@pytest.mark.slow
def test_the_pages_examples_are_what_the_commands_print_and_write(tmp_path):
    text = PAGE.read_text("utf-8")
    printed = []
    for argv in page_commands(text):
        result = subprocess.run([str(SIZEFX), *argv[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert result.returncode == 0, f"{shlex.join(argv)}: {result.stderr.strip()}"
        if argv[1] == "diagnose":
            printed.append([" ".join(line.split()) for line in (result.stdout + result.stderr).splitlines()])
    for block, lines in zip(_blocks(text, "text")[:2], printed):
        missing = [line for line in shown_lines(block) if line not in lines]
        assert not missing, f"shown on the page but not printed: {missing[:3]}"
    written = json.loads((tmp_path / "report.json").read_text("utf-8"))
    wrong = mismatches(excerpt(text), written)
    assert not wrong, f"{len(wrong)} values of the JSON excerpt differ from report.json: {wrong[:5]}"
