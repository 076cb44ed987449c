"""The documentation site builds with every warning an error, and reads as the repository host does.

``mkdocs build --strict`` fails on a link to a missing page, file or anchor and on a page left out
of the navigation; ``docs/mkdocs_hooks.py`` adds the README as the tutorial, copies the files the
pages link to outside ``docs/`` and stops on a link to a path that does not exist. The build takes
about 1 s, so it runs in the fast tier; mkdocs comes with the test extras (a missing one fails).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def hooks():
    spec = importlib.util.spec_from_file_location("sizefx_mkdocs_hooks", ROOT / "docs" / "mkdocs_hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-4000:]}"
    return out


def test_the_site_has_the_four_kinds_of_pages(site):
    for page in (
        "index.html",
        "tutorial/index.html",
        "howto/index.html",
        "reference/cli/index.html",
        "diagnose/index.html",
    ):
        assert (site / page).is_file(), page
    home = (site / "index.html").read_text()
    for kind in ("Tutorial", "How-to guides", "Reference", "Explanation"):
        assert kind in home


def test_links_outside_docs_are_copied_into_the_site(site):
    """A result file a page cites, a schema and a source file are in the site where its links point."""
    navigate = (site / "navigate" / "index.html").read_text()
    assert 'href="../_repo/benchmarks/results/bench_navigate.json"' in navigate
    assert (site / "_repo" / "benchmarks" / "results" / "bench_navigate.json").is_file()
    assert (site / "_repo" / "data-schemas" / "navigation-1.json").is_file()
    tutorial = (site / "tutorial" / "index.html").read_text()
    assert 'href="../calibrate/"' in tutorial  # README's docs/calibrate.md, as a site page


def test_lists_and_code_in_lists_render_as_on_the_repository_host(site):
    navigate = (site / "navigate" / "index.html").read_text()
    assert "<li>Coarse alignment" in navigate  # a 2-space nested list right after a paragraph line
    tutorial = (site / "tutorial" / "index.html").read_text()
    assert "<pre>" in tutorial.split("Install and run the demo", 1)[1].split("</li>", 1)[0]


def test_anchors_are_the_repository_hosts(hooks):
    assert hooks.github_slug("Cramér–Rao bound (CRB)") == "cramérrao-bound-crb"
    assert hooks.github_slug("`sizefx batch` over records") == "sizefx-batch-over-records"
    ids: set = set()
    assert [hooks.github_unique("x", ids) for _ in range(3)] == ["x", "x-1", "x-2"]


def test_a_link_to_a_missing_file_stops_the_build(hooks, tmp_path):
    page = hooks.DOCS / "navigate.md"
    with pytest.raises(hooks.PluginError, match="no such file benchmarks/results/gone.json"):
        hooks._resolve(page, "../benchmarks/results/gone.json")
    assert hooks._resolve(page, "https://doi.org/10.18522/2311-3103-2024-1-234-246") is None
    assert hooks._resolve(page, "#speed") is None


def test_gfm_lists_leave_code_and_tables_alone(hooks):
    text = "para\n- a\n  - b\n\n```sh\n  - not a list\n```\n| x |\n|---|\n"
    assert hooks.gfm_lists(text) == "para\n\n- a\n    - b\n\n```sh\n  - not a list\n```\n| x |\n|---|\n"
