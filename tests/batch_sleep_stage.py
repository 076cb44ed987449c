"""A stage for tests/test_fleet_safety.py: writes its worker's process id beside the record
(RECORD.pid), then sleeps 30 s and only then writes RECORD.late: a worker that outlived its batch
and went on writing would leave that file."""

import os
import time


class _Result:
    def to_json(self):
        return {}


def run(config):
    with open(config + ".pid", "w") as f:
        f.write(str(os.getpid()))
    time.sleep(30.0)
    open(config + ".late", "w").close()
    return _Result()
