"""One stage over many records: ``sizefx.batch.run(STAGE, INPUTS, OUT, options=...)``, which is
``sizefx batch STAGE ... INPUTS --out OUT``.

A test campaign is dozens of records; each goes through the very stage code the single-file
command runs (its config, made from the same option declarations, and the stage's ``run``), in
warm worker processes, into one folder with a manifest:

- :mod:`.campaign`: :func:`run`, the batch from its inputs to its result: each record's config and
  outputs (named after it in the folder), compare's partners paired by name, the option files read
  once, the folder's manifest read to resume; :mod:`.chains` the chain per flight (``"run"``).
- :mod:`.inputs`: the name each record's outputs get in the folder, compare's partners paired by
  name, and the check that no path the batch writes is one of its inputs. The records themselves
  (files, folders and globs expanded and checked: unreadable folders, duplicates, an output folder
  inside an input folder, anything but a regular file: one line, nothing written), the option
  files read once and the folder's lock are a chain's too: :mod:`sizefx.runs.folder`'s.
- :mod:`.manifest`: ``DIR/manifest.sqlite``, the store of each record's entry (the input and its
  SHA-256, the options, the outputs and theirs, the status: ok / refused with its one-line reason /
  failed, duration, peak memory and headline figures), one committed row per record, so that an
  interrupted campaign continues where it stopped (a record whose input hash, options and outputs
  match is skipped); and ``DIR/manifest.json`` (``sizefx/batch/1``), the same as one document,
  written when the batch ends.
- :mod:`.digests`: the stat cache: a file's SHA-256 taken from its size, times and inode while
  they are those it was hashed with, so that a re-run reads only what changed.
- :mod:`.runner`: the work in ``workers`` processes (the Numba kernels load from the on-disk
  cache once per process); one bad record never stops the others. :mod:`.worker` is what runs in
  each, :mod:`.outcome` the jobs, the entries and the batch's result with its report;
  :mod:`.folder` the files the batch keeps in its folder besides the records' outputs.
- :mod:`.fleet`: the records' headline figures side by side (each record's own are
  :mod:`sizefx.runs.figures`'s, a chain step's too), calibrations of one unit combined, and
  ``fleet.png``.

The outputs of a record do not depend on the number of workers or the order: each record is
the stage run on it alone, and the manifest lists the records sorted by input path.
"""

from __future__ import annotations

from .campaign import run
from .inputs import expand_inputs, output_names
from .manifest import BATCH_SCHEMA, read_manifest
from .runner import BatchJob, BatchResult, RecordOutcome, run_batch

__all__ = [
    "BATCH_SCHEMA",
    "BatchJob",
    "BatchResult",
    "RecordOutcome",
    "expand_inputs",
    "output_names",
    "read_manifest",
    "run",
    "run_batch",
]
