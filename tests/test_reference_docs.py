"""The generated reference pages (docs/reference/) say what the code says today.

``docs/reference/generate.py`` writes ``cli.md`` from the click commands and ``formats.md`` from
``data-schemas/``; here the pages are made again in memory and compared with the committed ones,
so that a changed option, help text or contract fails until the pages are regenerated.
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
GENERATOR = ROOT / "docs" / "reference" / "generate.py"
FIX = "run `python docs/reference/generate.py` from the repository root and commit the pages"
#: Lines of the diff shown in a failure (the whole diff is one command away).
DIFF_LINES = 40


@pytest.fixture(scope="module")
def generator():
    spec = importlib.util.spec_from_file_location("sizefx_reference_generate", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def pages(generator):
    return generator.render()


def test_the_committed_pages_are_what_the_sources_make(generator, pages):
    stale = generator.stale(pages)
    if stale:
        shown = "\n".join("\n".join(diff.splitlines()[:DIFF_LINES]) for diff in stale.values())
        pytest.fail(f"docs/reference/ is out of date ({', '.join(sorted(stale))}): {FIX}.\n{shown}", pytrace=False)


def test_every_command_and_option_is_on_the_cli_page(generator, pages):
    """Walked independently of the generator: each command path is a heading, each visible option
    is in its command's section."""
    text = pages["cli.md"]
    for name, command in generator.entry_points():
        todo = [(command, [name], None)]
        while todo:
            cmd, path, parent = todo.pop()
            ctx = click.Context(cmd, info_name=path[-1], parent=parent)
            heading = re.search(rf"^#+ `{re.escape(' '.join(path))}`$", text, re.M)
            assert heading, f"cli.md has no section for {' '.join(path)}"
            section = text[heading.end() : text.find("\n#", heading.end())]
            for param in cmd.params:
                if isinstance(param, click.Option) and not param.hidden:
                    for opt in param.opts + param.secondary_opts:
                        assert f"{opt}" in section, f"cli.md: {' '.join(path)} lacks {opt}"
            if isinstance(cmd, click.Group):
                todo += [(cmd.commands[n], [*path, n], ctx) for n in cmd.commands if not cmd.commands[n].hidden]


def test_every_schema_and_every_link_target_is_on_the_formats_page(generator, pages):
    text = pages["formats.md"]
    for path in sorted((ROOT / "data-schemas").glob("*.json")):
        doc = json.loads(path.read_text("utf-8"))
        ident = doc.get("$id") or doc["schema"]
        assert re.search(rf"^## {re.escape(ident)}$", text, re.M), f"formats.md has no section for {path.name}"
    for name, page in pages.items():
        anchors = {generator.slug(h) for h in re.findall(r"^#+ (.+)$", page, re.M)}
        for target in re.findall(r"\]\(#([^)]+)\)", page):
            assert target in anchors, f"{name}: a link to #{target}, which no heading makes"


def test_the_pages_hold_nothing_of_this_machine(pages):
    for name, page in pages.items():
        for local in (str(ROOT), str(Path.home())):
            assert len(local) < 2 or local not in page, (
                f"{name} holds the local path {local}: describe such a default instead"
            )
