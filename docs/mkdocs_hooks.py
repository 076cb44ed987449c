"""MkDocs hooks: the site is built from the same Markdown the repository host shows.

The pages under ``docs/`` link to files beside them in the repository (result files in
``benchmarks/results/``, schemas in ``data-schemas/``, sources in ``sizefx/``, ``README.md``,
``examples/``) and to folders, as a repository host resolves them. A site has only ``docs/``, so:

- ``README.md`` (the tutorial: quick start and the walk-through on an example recording) becomes the
  page ``tutorial.md``, its links to ``docs/...`` made relative to the site;
- every other file a page links to outside ``docs/`` is copied into the site under ``_repo/`` (the
  same path below it) and the link pointed there; a Markdown file so copied (``examples/README.md``)
  is rendered as a page, its own links treated the same way;
- a link to a folder goes to its ``README.md`` or, where it has none, to a generated page that lists
  its files (copied too);
- a link to a path that does not exist stops the build (inside ``docs/`` MkDocs' own link validation
  does that, with ``--strict``), so a moved result file cannot leave a dead link;
- headings get the repository host's anchors (lower case, punctuation dropped, spaces to hyphens,
  letters such as é kept), so ``page.md#cramér-rao-bound`` works in both places.

``mkdocs build --strict`` (``tests/test_site.py``) turns every warning into an error.
"""

from __future__ import annotations

import importlib.util
import os
import re
from pathlib import Path, PurePosixPath

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: Where files from outside docs/ go in the site.
REPO = "_repo"
#: README.md's page in the site.
TUTORIAL = "tutorial.md"
#: A Markdown link or image: ``[text](target)`` or ``[text](target "title")``, not inside code.
LINK = re.compile(r"(!?\[(?:[^\[\]]|\[[^\]]*\])*\]\()([^)\s]+)((?:\s+\"[^\"]*\")?\))")
FENCE = re.compile(r"^ {0,3}(```|~~~)")
CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1")
EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:|^#|^/")
#: The generated folder listings of this build (their links are written for the site already).
LISTINGS: set[str] = set()


def _reference_generator():
    """``docs/reference/generate.py``, whose :func:`slug` writes the reference pages' anchors (it
    imports only the standard library and click, which mkdocs brings)."""
    spec = importlib.util.spec_from_file_location("sizefx_reference_generate", DOCS / "reference" / "generate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_SLUG = _reference_generator().slug


def github_slug(value: str, separator: str = "-") -> str:
    """The anchor a repository host gives a heading, as the reference pages' generator writes them
    (``slug``: lower case, punctuation but ``-`` and ``_`` dropped, spaces as hyphens); the signature
    of the toc extension's ``slugify``, whose separator is always ``-`` here."""
    return _SLUG(value)


def github_unique(id: str, ids: set, counters: dict | None = None) -> str:
    """A repeated anchor as the repository host writes it: ``x``, ``x-1``, ``x-2`` (Python-Markdown
    writes ``x_1``); the signature of ``markdown.extensions.toc.unique``, which it replaces."""
    if id in ids or not id:
        n = 1
        while f"{id}-{n}" in ids:
            n += 1
        id = f"{id}-{n}"
    ids.add(id)
    return id


def _real_path(src_uri: str) -> Path:
    """The repository file a site page was made from."""
    if src_uri == TUTORIAL:
        return ROOT / "README.md"
    if src_uri.startswith(REPO + "/"):
        return ROOT / src_uri[len(REPO) + 1 :]
    return DOCS / src_uri


def _site_uri(real: Path) -> str:
    """The site path of a repository file: its place under docs/, the tutorial, or under _repo/."""
    if real == ROOT / "README.md":
        return TUTORIAL
    if real.is_relative_to(DOCS):
        return real.relative_to(DOCS).as_posix()
    return f"{REPO}/{real.relative_to(ROOT).as_posix()}"


def _folder_page(real: Path) -> str:
    """The site page a link to the folder ``real`` goes to: its README.md, else its listing."""
    if (real / "README.md").is_file():
        return _site_uri(real / "README.md")
    return _site_uri(real) + "/index.md"


def _links(markdown: str):
    """(start, end, target) of every link outside fenced code blocks and code spans (a link's text
    may run over lines)."""
    masked, fenced = [], None
    for line in markdown.splitlines(keepends=True):
        opened = FENCE.match(line)
        if opened and (fenced is None or opened.group(1) == fenced):
            fenced = None if fenced else opened.group(1)
            masked.append(" " * len(line.rstrip("\n")) + line[len(line.rstrip("\n")) :])
        elif fenced is not None:
            masked.append(" " * len(line.rstrip("\n")) + line[len(line.rstrip("\n")) :])
        else:
            masked.append(CODE_SPAN.sub(lambda m: " " * len(m.group(0)), line))
    text = "".join(masked)
    for m in LINK.finditer(text):
        yield m.start(2), m.end(2), markdown[m.start(2) : m.end(2)]


def _resolve(page_real: Path, target: str) -> tuple[Path, str] | None:
    """The repository path a relative link of the page at ``page_real`` names, and its fragment;
    None for an external link or an anchor on the same page."""
    if EXTERNAL.match(target):
        return None
    path, _, fragment = target.partition("#")
    real = Path(os.path.normpath(page_real.parent / path))
    if not real.is_relative_to(ROOT):
        raise PluginError(f"{page_real.relative_to(ROOT)}: link {target!r} leaves the repository")
    if not real.exists():
        raise PluginError(f"{page_real.relative_to(ROOT)}: link {target!r}: no such file {real.relative_to(ROOT)}")
    return real, fragment


def on_config(config):
    """The repository host's anchors: the toc extension's ``slugify`` option, and its module-level
    ``unique`` (no option reaches it), replaced for this build's process only."""
    import markdown.extensions.toc

    toc = config.mdx_configs.setdefault("toc", {})
    toc["slugify"] = github_slug
    markdown.extensions.toc.unique = github_unique
    return config


def on_files(files: Files, *, config) -> Files:
    """Add the tutorial and every file outside docs/ (or folder listing) that a page links to,
    following the links of added Markdown pages too."""
    todo = [ROOT / "README.md"] + [DOCS / f.src_uri for f in files.documentation_pages()]
    added: set[str] = set()

    def add(uri: str, *, real: Path | None = None, content: str | None = None):
        if uri in added or files.get_file_from_path(uri) is not None:
            return
        added.add(uri)
        if content is not None:
            files.append(File.generated(config, uri, content=content))
        else:
            files.append(File.generated(config, uri, abs_src_path=str(real)))

    add(TUTORIAL, real=ROOT / "README.md")
    seen: set[Path] = set()
    while todo:
        page = todo.pop()
        if page in seen:
            continue
        seen.add(page)
        for _, _, target in _links(page.read_text(encoding="utf-8")):
            found = _resolve(page, target)
            if found is None:
                continue
            real, _ = found
            if real.is_dir():
                if not (real / "README.md").is_file():
                    listed = sorted(p for p in real.iterdir() if p.is_file() and not p.name.startswith("."))
                    lines = [f"# `{real.relative_to(ROOT).as_posix()}/`", ""]
                    for p in listed:
                        lines.append(f"- [`{p.name}`]({p.name})")
                        if not p.is_relative_to(DOCS):
                            add(_site_uri(p), real=p)
                    LISTINGS.add(_folder_page(real))
                    add(_folder_page(real), content="\n".join(lines) + "\n")
                else:
                    todo.append(real / "README.md")
                    if not real.is_relative_to(DOCS):
                        add(_site_uri(real / "README.md"), real=real / "README.md")
            elif not real.is_relative_to(DOCS):
                add(_site_uri(real), real=real)
                if real.suffix == ".md":
                    todo.append(real)
    return files


LIST_ITEM = re.compile(r"^( *)(?:[-*+]|\d{1,9}[.)])[ \t]")


def _list_indent(indent: int) -> int:
    """A list line's indent for Python-Markdown: each level 4 spaces where the repository host
    takes 2 (or 3, under ``1.``)."""
    return 4 * (indent // 2) if indent >= 2 else indent


def gfm_lists(markdown: str) -> str:
    """Lists as the repository host reads them, for Python-Markdown: a list may follow a paragraph
    line without a blank line (one is put in), and what is nested in a list item (a list, a
    paragraph, a fenced code block) is indented by 2 or 3 spaces (re-indented to the 4 per level
    Python-Markdown needs). Code blocks outside lists are left alone."""
    out: list[str] = []
    in_list, fence, shift, previous = False, None, None, ""
    for line in markdown.split("\n"):
        if fence is not None:  # inside a fenced block: moved as its opening fence was
            if shift is not None:
                old, new = shift
                cut = min(old, len(line) - len(line.lstrip(" ")))
                line = " " * new + line[cut:]
            if line.strip().startswith(fence):
                fence, shift = None, None
            out.append(line)
            previous = line
            continue
        opened = FENCE.match(line)
        indent = len(line) - len(line.lstrip(" "))
        item = LIST_ITEM.match(line)
        if opened:
            fence = opened.group(1)
            if in_list and indent:
                shift = (indent, _list_indent(indent))
                line = " " * shift[1] + line.lstrip(" ")
        elif not line.strip():
            pass
        elif item and not indent:
            if not in_list and previous.strip() and not previous.lstrip().startswith("|"):
                out.append("")
            in_list = True
        elif in_list and indent:
            line = " " * _list_indent(indent) + line.lstrip(" ")
        elif not previous.strip():
            in_list = False
        out.append(line)
        previous = line
    return "\n".join(out)


def on_page_markdown(markdown: str, *, page, config, files) -> str:
    """Lists read as on the repository host (:func:`gfm_lists`), and each relative link pointed at
    the site's copy of its target, relative to this page."""
    markdown = gfm_lists(markdown)
    src_uri = page.file.src_uri
    if src_uri in LISTINGS:
        return markdown  # a generated folder listing: its links are already the site's
    real_page = _real_path(src_uri)
    here = PurePosixPath(src_uri).parent
    out, last = [], 0
    for start, end, target in _links(markdown):
        found = _resolve(real_page, target)
        if found is None:
            continue
        real, fragment = found
        uri = _folder_page(real) if real.is_dir() else _site_uri(real)
        new = os.path.relpath(uri, here).replace(os.sep, "/") + (f"#{fragment}" if fragment else "")
        out.append(markdown[last:start] + new)
        last = end
    return "".join(out) + markdown[last:]
