"""A batch's records: files, folders and globs expanded and checked, and their output names."""

from __future__ import annotations

import fnmatch
import os
from pathlib import Path

from ..errors import ConfigError
from ..io.files import regular_file

__all__ = [
    "expand_inputs",
    "output_names",
    "check_out_dir",
    "make_out_dir",
    "check_writes",
    "check_stage_options",
    "resolve_path",
    "record_key",
    "pair_inputs",
    "check_option_files",
    "RECORD_SUFFIXES",
    "KEY_SUFFIXES",
]

#: What a folder given as an input contributes: its telemetry files (not recursively: a campaign's
#: folder of records; give a glob such as ``runs/**/*.h5`` for a tree).
RECORD_SUFFIXES = (".h5", ".hdf5")
#: Glob characters: an input with one of them is a pattern, not a path.
_GLOB = set("*?[")


#: Directory entries a glob may visit before it is refused: a tree this large is not a campaign's
#: folder, and a walk of it would run for minutes before anything is checked.
GLOB_MAX_ENTRIES = 1_000_000


def _glob(pattern: str) -> list[Path]:
    """The regular files ``pattern`` matches: ``*``, ``?`` and ``[...]`` within a name, ``**`` for any
    number of folders. As the shell's globs, names that begin with a dot match only a pattern that
    does, and folders that cannot be read are passed over.

    Unlike :func:`glob.glob`, a ``**`` never descends into a link to a folder: a link back to a parent
    would make the walk endless, and a link elsewhere would take it out of the tree the pattern names.
    (A link named by a pattern's own component, ``runs/*/imu.h5``, is followed: each component goes
    one level down.) A walk of more than :data:`GLOB_MAX_ENTRIES` entries is refused."""
    parts = Path(pattern).parts
    first = next((k for k, part in enumerate(parts) if _GLOB & set(part)), len(parts))
    root = Path(*parts[:first]) if first else Path(".")
    rest = parts[first:]
    if rest and rest[-1] == "**":  # ``runs/**``: every file below, as ``runs/**/*``
        rest = (*rest, "*")
    found: list[Path] = []
    seen: set[tuple[int, int, int]] = set()
    visited = 0
    stack = [(root, 0)]
    while stack:
        folder, k = stack.pop()
        try:
            info = os.stat(folder)
        except OSError:
            continue
        key = (info.st_dev, info.st_ino, k)
        if key in seen:  # reached twice (``**/**``, a bind mount): walked once
            continue
        seen.add(key)
        part, last = rest[k], k == len(rest) - 1
        if part == "**":
            stack.append((folder, k + 1))  # ``**`` matches no folder at all, too
        try:
            with os.scandir(folder) as entries:
                for entry in entries:
                    visited += 1
                    if visited > GLOB_MAX_ENTRIES:
                        raise ConfigError(
                            f"{pattern}: the pattern walks more than {GLOB_MAX_ENTRIES:,} files and folders; "
                            "narrow it to the campaign's folder"
                        )
                    name = entry.name
                    if part == "**":
                        if not name.startswith(".") and entry.is_dir(follow_symlinks=False):
                            stack.append((Path(entry.path), k))
                        continue
                    if name.startswith(".") and not part.startswith("."):
                        continue
                    if not fnmatch.fnmatchcase(name, part):
                        continue
                    if last:
                        if entry.is_file():  # a regular file, links followed: FIFOs and devices are left out
                            found.append(Path(entry.path))
                    elif entry.is_dir():
                        stack.append((Path(entry.path), k + 1))
        except OSError:  # a folder that cannot be read: passed over, as the shell does
            continue
    return sorted(found)


def expand_inputs(inputs) -> list[Path]:
    """The records the inputs name, resolved, in a stable order (sorted by path): each file as
    given; each folder's ``*.h5``/``*.hdf5`` files; each glob's matches (:func:`_glob`; ``**``
    recursive, without following links to folders).

    Refused in one line (:class:`~sizefx.errors.ConfigError`): no inputs, or an empty one; a path
    that does not exist; anything but a regular file or a folder (a FIFO, a device: it would never
    end); a folder that cannot be read or holds no record; a glob that matches nothing; the same
    record twice (also through another spelling or a link)."""
    if not inputs:
        raise ConfigError("no inputs: give record files, folders of them, or globs (e.g. 'runs/*.h5')")
    records: dict[Path, str] = {}
    for given in inputs:
        text = str(given)
        if not text.strip():
            raise ConfigError("an empty input (''): give record files, folders of them, or globs")
        if _GLOB & set(text):
            matches = _glob(text)
            if not matches:
                raise ConfigError(
                    f"{text}: the pattern matches no file; check it (quote it so the shell does not expand it first)"
                )
        else:
            path = Path(text)
            if not path.exists():
                raise ConfigError(f"{path}: no such file or folder; check the path")
            if path.is_dir():
                if not os.access(path, os.R_OK | os.X_OK):
                    raise ConfigError(f"{path}: the folder cannot be read (permissions); fix them or leave it out")
                matches = sorted(p for p in path.iterdir() if p.suffix.lower() in RECORD_SUFFIXES and p.is_file())
                if not matches:
                    raise ConfigError(
                        f"{path}: the folder holds no record ({', '.join(RECORD_SUFFIXES)}); give the files or a glob"
                    )
            else:
                matches = [regular_file(path)]
        for match in matches:
            regular_file(match)  # a glob's or a folder's match may have changed since it was listed
            resolved = match.resolve()
            if resolved in records:
                raise ConfigError(f"{match}: given twice (also as {records[resolved]}); each record once")
            records[resolved] = str(match)
    return sorted(records)


def resolve_path(path, what: str) -> Path:
    """``path`` made absolute with every link followed (a new path's existing part), or a one-line
    refusal naming ``what`` (a link loop)."""
    try:
        return Path(path).resolve()
    except (OSError, RuntimeError) as exc:  # RuntimeError: Python 3.11's "Symlink loop"
        raise ConfigError(f"{path}: {what} cannot be resolved ({_one_line(exc)}); check its links") from None


def check_out_dir(out_dir, inputs, records) -> Path:
    """The output folder (resolved), refused in one line when it cannot hold a batch's outputs: empty,
    a file, a link loop, in a folder that does not exist or cannot be written; an input folder or
    inside one (a re-run would take its outputs for records); or a folder holding one of the
    ``records`` (the files the batch reads), however they were named (a glob the shell expanded
    included). What each record will write is checked later, path by path (:func:`check_writes`)."""
    text = "" if out_dir is None else str(out_dir)
    if not text.strip():
        raise ConfigError("--out '': give the folder for the outputs (it is made if new)")
    out = resolve_path(text, "--out")
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out_dir}: --out exists and is not a folder; give a folder (it is made if new)")
    folder = out if out.exists() else out.parent
    if not folder.is_dir():
        raise ConfigError(f"{out_dir}: --out's parent folder does not exist; make it first")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"{out_dir}: --out cannot be written in {folder} (permissions); give another folder")
    for given in inputs:
        text = str(given)
        folder = Path(text.split("*")[0].split("?")[0].split("[")[0] or ".") if _GLOB & set(text) else Path(text)
        if folder.is_dir():
            folder = folder.resolve()
            if out == folder or folder in out.parents:
                raise ConfigError(
                    f"{out_dir}: --out is inside the input folder {given}; a re-run would read the "
                    "outputs as records: put it elsewhere"
                )
    for record in records:
        record = Path(record).resolve()
        if record == out:
            raise ConfigError(f"{out_dir}: --out is one of the inputs; give a new folder")
        if out in record.parents:
            raise ConfigError(
                f"{out_dir}: --out holds the input {record}; outputs and records would mix (a later glob "
                "would take outputs for records): give the outputs a folder of their own"
            )
    return out


def make_out_dir(out: Path) -> Path:
    """Make the output folder ``out`` (checked by :func:`check_out_dir`) if it is new, or refuse in one
    line when it cannot be made (a file system that refuses it: ``/proc``, a read-only mount)."""
    try:
        out.mkdir(exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"{out}: --out cannot be made ({exc.strerror or exc}); give another folder") from None
    if not out.is_dir():
        raise ConfigError(f"{out}: --out is not a folder; give a folder")
    return out


def check_writes(out: Path, jobs, own: dict | None = None) -> None:
    """Refuse, before anything is written, a batch that would write over one of its own inputs or
    write one path twice: every path the ``jobs`` write (their ``outputs`` and ``summary_path``,
    files or folders) is resolved with its links followed and compared with every resolved input
    (each job's record and ``paired`` files: option files, partners) and with the batch's own files
    in ``out`` (``own``: path -> what it is, e.g. the manifest). Also refused: an input inside a
    folder a job writes. One line names the record, the path and what it collides with."""
    inputs: dict[Path, str] = {}
    for job in jobs:
        inputs.setdefault(resolve_path(job.input, "a record"), f"the record {job.input}")
        for option, path in job.paired.items():
            inputs.setdefault(resolve_path(path, option), f"{option} {path}")
    taken = {resolve_path(path, what): what for path, what in (own or {}).items()}
    for job in jobs:
        written = {**job.outputs, **({"summary": job.summary_path} if job.summary_path else {})}
        for option, path in written.items():
            target = resolve_path(path, f"record {job.name}'s {option}")
            if target in inputs:
                raise ConfigError(
                    f"{path}: record {job.name}'s output would overwrite {inputs[target]}; nothing was "
                    "written: give --out a folder of its own"
                )
            if target in taken:
                raise ConfigError(
                    f"{path}: record {job.name}'s output is also {taken[target]}; nothing was written: "
                    "rename the record or give another --out"
                )
            taken[target] = f"record {job.name}'s output"
    for target, what in inputs.items():
        for folder in target.parents:
            if folder in taken:
                raise ConfigError(
                    f"{target}: {what} lies in {folder}, which {taken[folder]} writes; nothing was "
                    "written: give --out a folder of its own"
                )


def check_stage_options(config) -> None:
    """A batch's stage options checked once, before its first record: its option files
    (:func:`check_option_files`); the options themselves were checked when the config was made."""
    check_option_files({k: v for k, v in config.inputs().items() if v and str(k).split()[-1].startswith("-")})


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def output_names(records: list[Path]) -> dict[Path, str]:
    """A name for each record's outputs in the batch folder: its stem, or, where stems repeat
    (``run1/imu.h5``, ``run2/imu.h5``), as many parent folders as make it unique, joined by ``__``
    (``run1__imu``; ``imu_hdf5`` beside ``imu_h5`` in one folder). Depends only on the set of
    records, not their order."""
    parts = {r: r.with_suffix("").parts[1:] for r in records}
    depth = {r: 1 for r in records}
    while True:
        names = {r: "__".join(parts[r][-depth[r] :]) for r in records}
        seen: dict[str, list[Path]] = {}
        for r, name in names.items():
            seen.setdefault(name, []).append(r)
        clashes = [group for group in seen.values() if len(group) > 1]
        if not clashes:
            return names
        for group in clashes:
            if all(depth[r] == len(parts[r]) for r in group):  # the same path but the suffix (imu.h5, imu.hdf5)
                for r in group:
                    parts[r] = (*parts[r][:-1], f"{parts[r][-1]}_{r.suffix.lstrip('.')}")
            for r in group:
                depth[r] = min(depth[r] + 1, len(parts[r]))


#: What a file's name ends with after its record's name, longest first: the solutions of
#: ``sizefx navigate``/``sizefx batch navigate`` (``NAME.nav.h5``), compensated records
#: (``NAME.compensated.h5``), and the records themselves.
KEY_SUFFIXES = (".compensated.h5", ".nav.h5", ".hdf5", ".h5")


def record_key(path) -> str:
    """The record a file belongs to, from its name: ``flight07.nav.h5``, ``flight07.compensated.h5``
    and ``flight07.h5`` all give ``flight07``."""
    name = Path(path).name
    for suffix in KEY_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return Path(name).stem


def pair_inputs(records: list[Path], given, option: str) -> dict[Path, Path]:
    """Each record's partner among the files ``given`` to ``option`` (files, folders, globs, as
    :func:`expand_inputs` takes them): one file given is every record's partner; otherwise each
    record is paired with the file of the same :func:`record_key` (``runs/flight07.nav.h5`` with
    ``plain/flight07.nav.h5`` or ``flights/flight07.h5``).

    Refused in one line: a record without a partner, two files with one key, a record paired with
    itself."""
    partners = expand_inputs(given)
    if len(partners) == 1:
        pairs = {r: partners[0] for r in records}
    else:
        by_key: dict[str, Path] = {}
        for p in partners:
            key = record_key(p)
            if key in by_key:
                raise ConfigError(f"{option}: {by_key[key]} and {p} both belong to '{key}'; give one file per record")
            by_key[key] = p
        pairs = {}
        for r in records:
            key = record_key(r)
            if key not in by_key:
                raise ConfigError(
                    f"{option}: nothing for {r.name} among {len(partners)} files (looked for '{key}' "
                    f"with {', '.join(KEY_SUFFIXES)}); give its file or leave the record out"
                )
            pairs[r] = by_key[key]
    for r, p in pairs.items():
        if p == r:
            raise ConfigError(f"{option}: {r} would be compared with itself; give the other solutions")
    return pairs


def _option_readers() -> dict:
    """Option -> the reader that owns its file, imported when an option names a file (the readers load
    NumPy, the schemas and, for a model, Numba)."""

    def load_model(path):
        from ..correct import load_model

        return load_model(path)

    def levers(name):
        def read(path):
            from .. import levers

            return getattr(levers, name)(path)

        return read

    return {"--levers": levers("read_levers"), "--nominal": levers("nominal_levers"), "--model": load_model}


def check_option_files(option_files: dict) -> None:
    """The files the options name (``{"--levers": path, ...}``, or a chain's ``{"navigate --levers":
    path, ...}``), each read once by its own reader before any record runs: a missing, unreadable or
    invalid one is the whole run's fault, refused in the reader's one line (ConfigError, exit 2)
    instead of once per record. Other files (records, ``--against``, ``--reference``) are only
    pre-flighted here; their contents are judged with their records."""
    from ..stage import preflight

    preflight(inputs=option_files, outputs={})
    readers = _option_readers()
    for option, path in option_files.items():
        reader = readers.get(str(option).split()[-1]) if option else None
        if reader is not None and path:
            reader(path)
