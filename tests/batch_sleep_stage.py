"""A stage for tests/test_fleet_safety.py: writes its worker's process id beside the record
(RECORD.pid), sleeps as many seconds as the record file says (30 when it is empty; the environment's
SLEEP_STAGE_S, where set, instead), and only then
writes RECORD.late as any stage writes an output (atomically): a worker that outlived its batch,
or a Dask task its batch gave up, and went on writing would leave that file."""

import os
import time

from sizefx.io.files import atomic_output


class _Result:
    def to_json(self):
        return {}


def run(config):
    with open(config + ".pid", "w") as f:
        f.write(str(os.getpid()))
    with open(config) as f:
        time.sleep(float(os.environ.get("SLEEP_STAGE_S") or f.read() or 30.0))
    with atomic_output(config + ".late", force=True) as tmp:
        open(tmp, "w").close()
    return _Result()
