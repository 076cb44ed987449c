"""A stage for tests/test_batch.py whose worker process dies on the record named "crash" (as one killed
by the kernel for memory would), and succeeds on the others."""

import os


class _Result:
    def __init__(self, path):
        self.path = path

    def to_json(self):
        return {"record": str(self.path)}


def run(config):
    if config.endswith("crash.h5"):
        os._exit(9)
    return _Result(config)
