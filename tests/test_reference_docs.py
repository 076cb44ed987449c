"""The generated reference pages (docs/reference/) say what the code says today.

``docs/reference/generate.py`` writes ``cli.md`` from the click commands, ``formats.md`` from
``data-schemas/`` and ``api.md`` from the public modules' ``__all__`` and docstrings; here the pages
are made again in memory and compared with the committed ones, so that a changed option, help text,
contract, signature or docstring fails until the pages are regenerated.

Making api.md imports the public modules (numpy, scipy, h5py, numba: about 1.5 s in a fresh
process, no kernel compiled); the whole file runs in about 2 s, so it stays in the fast tier.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import re
from collections import Counter
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


def test_every_schema_is_on_the_formats_page(generator, pages):
    text = pages["formats.md"]
    for path in sorted((ROOT / "data-schemas").glob("*.json")):
        doc = json.loads(path.read_text("utf-8"))
        ident = doc.get("$id") or doc["schema"]
        assert re.search(rf"^## {re.escape(ident)}$", text, re.M), f"formats.md has no section for {path.name}"


def test_every_public_name_is_on_the_api_page(generator, pages):
    """Each module of ``API_MODULES`` imports and has a section; each name of its ``__all__`` exists
    and has a heading in it (read from the module here, not from the generator's walk)."""
    text = pages["api.md"]
    for module_name in generator.API_MODULES:
        module = importlib.import_module(module_name)
        heading = re.search(rf"^## `{re.escape(module_name)}`$", text, re.M)
        assert heading, f"api.md has no section for {module_name}"
        end = text.find("\n## ", heading.end())
        section = text[heading.end() : end if end >= 0 else len(text)]
        for name in vars(module).get("__all__", ()):
            assert hasattr(module, name), f"{module_name}.__all__ lists {name!r}, which the module does not define"
            assert re.search(rf"^### `{re.escape(module_name)}\.{re.escape(name)}`$", section, re.M), (
                f"api.md: {module_name} lacks {name}"
            )


def test_every_link_goes_to_a_heading_of_its_page(generator, pages):
    """GitHub's anchors: the heading's slug, numbered when a slug comes again (``x``, ``x-1``)."""
    for name, page in pages.items():
        anchors, seen = set(), Counter()
        for heading in re.findall(r"^#+ (.+)$", page, re.M):
            base = generator.slug(heading)
            anchors.add(f"{base}-{seen[base]}" if seen[base] else base)
            seen[base] += 1
        for target in re.findall(r"\]\(#([^)]+)\)", page):
            assert target in anchors, f"{name}: a link to #{target}, which no heading makes"


def test_the_pages_hold_nothing_of_this_machine(pages):
    for name, page in pages.items():
        for local in (str(ROOT), str(Path.home())):
            assert len(local) < 2 or local not in page, (
                f"{name} holds the local path {local}: describe such a default instead"
            )
        address = re.search(r"\bat 0x[0-9A-Fa-f]+", page)
        assert address is None, f"{name} holds an object's address ({address and address[0]}): it differs each run"
