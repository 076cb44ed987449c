"""Atomic, non-destructive output files.

Every output of sizefx is written to a temporary file in the destination
directory and renamed into place only when complete, so a crash or Ctrl-C
never leaves a half-written file under the final name. An output never
replaces one of the inputs of the same run, and replaces an existing file
only when the caller says ``force=True``.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ..errors import OutputError

__all__ = ["atomic_output", "check_output_path", "check_outputs", "check_output_folder"]


def _require_writable_parent(out: Path) -> None:
    """The folder that will hold the new file or folder ``out`` exists and is writable."""
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{out}: directory {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{out}: directory {parent} is not writable; choose another output folder")


def check_output_path(path, *, inputs=(), force: bool = False) -> Path:
    """Refuse an output path that is an input, or that exists without ``force``."""
    out = Path(path)
    for inp in inputs:
        if inp is None:
            continue
        inp = Path(inp)
        same = False
        if out.exists() and inp.exists():
            same = os.path.samefile(out, inp)
        else:
            same = out.resolve() == inp.resolve()
        if same:
            raise OutputError(f"{out}: output would overwrite the input {inp}; choose another output name")
    if out.exists() and not force:
        raise OutputError(f"{out}: output exists; pass --force to replace it, or choose another name")
    if out.exists() and out.is_dir():
        raise OutputError(f"{out}: output is a directory; give a file name")
    _require_writable_parent(out)
    return out


def check_outputs(outputs: dict, *, inputs=(), force: bool = False) -> None:
    """Pre-flight for every output of one command, before any work: ``outputs`` maps each option
    (``"--json"``) to its path or None. Two outputs may not share a path, and each passes
    :func:`check_output_path` (not an input, not existing without ``force``, folder exists)."""
    given = {opt: Path(path) for opt, path in outputs.items() if path}
    seen: dict = {}
    for opt, path in given.items():
        key = path.resolve()
        if key in seen:
            raise OutputError(f"{path}: given to both {seen[key]} and {opt}; each output needs its own file")
        seen[key] = opt
        check_output_path(path, inputs=inputs, force=force)


def check_output_folder(folder, *, option: str, inputs=()) -> Path:
    """Refuse an output folder (``--plots``) that is a file or an input, or cannot be made.

    The folder may exist (its files are then checked one by one, as outputs) or be new, in an
    existing, writable folder, as for an output file.
    """
    out = Path(folder)
    if out.exists():
        if not out.is_dir():
            is_input = any(inp is not None and Path(inp).exists() and os.path.samefile(out, inp) for inp in inputs)
            raise OutputError(f"{out}: {option} needs a directory, and this is {'an input' if is_input else 'a'} "
                              "file; give a folder")
        if not os.access(out, os.W_OK | os.X_OK):
            raise OutputError(f"{out}: {option}: the folder is not writable; choose another folder")
        return out
    _require_writable_parent(out)
    return out


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(path, *, inputs=(), force: bool = False, suffix: str = ".tmp"):
    """Yield a temporary path next to ``path``; rename it to ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    """
    out = check_output_path(path, inputs=inputs, force=force)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=suffix, dir=out.parent if str(out.parent) else ".")
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        # mkstemp creates 0600; an output gets the permissions any new file would (umask applied)
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, out)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise
