"""A batch's records: their output names, their partners, and the check that no path the batch writes
is one of its inputs or written twice.

The records the inputs name (files, folders and globs expanded and checked), the option files read
once, and the output folder checked and made are a chain's too: they live in
:mod:`sizefx.runs.folder`, and their names are imported here too.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from ..runs.folder import (
    RECORD_SUFFIXES,
    check_option_files,
    check_out_dir,
    expand_inputs,
    make_out_dir,
    resolve_path,
)

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
