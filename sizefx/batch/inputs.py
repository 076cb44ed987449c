"""A batch's records: files, folders and globs expanded and checked, and their output names."""

from __future__ import annotations

import glob
import os
from pathlib import Path

from ..errors import ConfigError

__all__ = [
    "expand_inputs",
    "output_names",
    "check_out_dir",
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


def expand_inputs(inputs) -> list[Path]:
    """The records the inputs name, resolved, in a stable order (sorted by path): each file as
    given; each folder's ``*.h5``/``*.hdf5`` files; each glob's matches (``**`` recursive).

    Refused in one line (:class:`~sizefx.errors.ConfigError`): no inputs; a path that does not
    exist; a folder that cannot be read or holds no record; a glob that matches nothing; the same
    record twice (also through another spelling or a link)."""
    if not inputs:
        raise ConfigError("no inputs: give record files, folders of them, or globs (e.g. 'runs/*.h5')")
    records: dict[Path, str] = {}
    for given in inputs:
        text = str(given)
        if _GLOB & set(text):
            matches = sorted(Path(p) for p in glob.glob(text, recursive=True) if Path(p).is_file())
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
                matches = [path]
        for match in matches:
            resolved = match.resolve()
            if resolved in records:
                raise ConfigError(f"{match}: given twice (also as {records[resolved]}); each record once")
            if not os.access(resolved, os.R_OK):
                raise ConfigError(f"{match}: cannot be read (permissions); fix them or leave it out")
            records[resolved] = str(match)
    return sorted(records)


def check_out_dir(out_dir, inputs, records) -> Path:
    """The output folder, refused when it is an input folder or inside one (a re-run would take its
    outputs for records), or an input file, or in a folder that does not exist."""
    out = Path(out_dir).resolve()
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out_dir}: --out exists and is not a folder; give a folder (it is made if new)")
    if not out.parent.is_dir():
        raise ConfigError(f"{out_dir}: --out's parent folder does not exist; make it first")
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
    if out in records:
        raise ConfigError(f"{out_dir}: --out is one of the inputs; give a new folder")
    return out


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
    """Option -> the reader that owns its file (imported here: the readers load NumPy and the schemas)."""
    from ..correct import load_model
    from ..levers import nominal_levers, read_levers

    return {"--levers": read_levers, "--nominal": nominal_levers, "--model": load_model}


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
