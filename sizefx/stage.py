"""The shape every stage shares, and the pre-flight each one runs before any work.

A stage is one of ``simulate``, ``import``, ``inspect``, ``calibrate``, ``compensate``,
``navigate``, ``diagnose`` and ``compare``. Each exposes the same three things:

- a **config**: a frozen dataclass with everything the stage needs, input and output paths,
  ``force`` and the options, in SI units where they are quantities;
- a **result**: a dataclass of what it found and wrote, with ``report() -> str`` (the lines the
  command line prints) and ``to_json() -> dict``;
- ``run(config, *, progress=None) -> result``, which calls :func:`preflight` first.

The command line builds the config from its options, calls ``run`` and prints
``result.report()``; a Python caller makes the same call. ``progress(done, total)``, when
given, is called as the work advances (the command line passes ``sizefx_cli.options.Progress``,
a tqdm bar on a terminal).

The config names its files by the option a user gave them with (``inputs()`` and
``outputs()`` map ``"FILE"``, ``"--levers"``, ``"-o"`` ... to paths), so that every refusal
names both the path and the option.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike
from pathlib import Path

from .errors import ConfigError
from .io.files import check_output_folder, check_outputs, regular_file

__all__ = ["preflight", "helper_threads", "use_helper_threads"]

_helper_threads = True


def helper_threads() -> bool:
    """Whether a stage may run a helper thread beside its own in this process (``sizefx navigate``
    reads and checks the next chunk while it integrates this one).

    On by default: where a core is idle the helper shortens a record's wall time. A batch turns it
    off in workers that together fill the machine's cores (:func:`use_helper_threads`), where the
    helper could only take time from another worker's record: 8 records of the 1.8 h flight on 2
    workers and 2 cores took 13.9 s without it against 14.3 s with it (3 runs each).
    """
    return _helper_threads


def use_helper_threads(allowed: bool) -> None:
    """Allow or forbid :func:`helper_threads` in this process (a batch worker calls it at start)."""
    global _helper_threads
    _helper_threads = bool(allowed)


def preflight(
    *,
    inputs: Mapping[str, str | PathLike[str] | None],
    outputs: Mapping[str, str | PathLike[str] | None],
    force: bool = False,
    folders: Mapping[str, str | PathLike[str] | None] | None = None,
) -> None:
    """Refuse, before any work, what would fail later or destroy something.

    ``inputs`` and ``outputs`` map the option that named each file to its path (None: not
    given). Every input must be an existing regular file (not a FIFO or a device). Every output must be new (or ``force``),
    writable, in an existing folder, distinct from the other outputs and from every input,
    also through links (:func:`sizefx.io.files.check_outputs`). ``folders`` maps an option to
    an output folder (``--plots``): an existing folder, or a new one in an existing, writable
    folder (:func:`sizefx.io.files.check_output_folder`); the files a stage writes into it are
    among ``outputs``.
    """
    given = {opt: Path(p) for opt, p in inputs.items() if p is not None and str(p) != ""}
    for opt, path in given.items():
        if path.is_dir():
            raise ConfigError(f"{path}: {opt}: is a directory; give a file")
        regular_file(path, opt)  # a FIFO or a device would block or never end: refused before it is opened
    for opt, folder in (folders or {}).items():
        if folder is not None and str(folder) != "":
            check_output_folder(folder, option=opt, inputs=list(given.values()))
    check_outputs(dict(outputs), inputs=list(given.values()), force=force)
