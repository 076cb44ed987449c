"""Files in and out: the contracts of ``data-schemas/``, the readers and writers that follow them.

- :mod:`sizefx.io.schema`: the contracts (dataset names, units, JSON Schemas), loaded once, and the
  JSON Schema validation of every JSON document sizefx writes or reads (``jsonschema``).
- :mod:`sizefx.io.telemetry`: ``sizefx/telemetry/1`` records, read whole or streamed, and written;
  the facade of :mod:`~sizefx.io.records`, :mod:`~sizefx.io.gaps`, :mod:`~sizefx.io.contract`,
  :mod:`~sizefx.io.reader` and :mod:`~sizefx.io.writer` (import from it).
- :mod:`sizefx.io.files`: atomic outputs and the output pre-flight every stage shares.
- :mod:`sizefx.io.toml`: TOML written from a document (``tomli-w``).

Nothing is imported here, so that ``import sizefx.io.schema`` costs no h5py.
"""
