"""What a chain of stages (:mod:`sizefx.chain`, ``sizefx run``) and a batch (:mod:`sizefx.batch`,
``sizefx batch``) share, below both (a batch runs chains, so nothing the chain needs may live in
the batch):

- :mod:`.folder`: a campaign's folder: the records its inputs name (files, folders, globs), the
  option files read once by their readers, the output folder checked and made, its lock.
- :mod:`.figures`: a stage result's headline figures (run.json's steps, the manifest's records)
  and the few a table prints.

Nothing is imported here: each module is imported by its name.
"""
