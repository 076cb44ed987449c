"""A stage for tests/test_batch.py whose worker process dies on the record named "crash" (as one killed
by the kernel for memory would), dies once on "killonce" (a worker lost mid-record), asks for 4 GiB on "hog" (a record beyond the
worker's memory bound), takes 3 s on "slow" (and marks RECORD.finished only then), and succeeds on
the others, writing beside each record whether its worker allows helper threads (RECORD.helpers)."""

import os
import time

import numpy as np

from sizefx.stage import helper_threads


class _Result:
    def __init__(self, path):
        self.path = path

    def to_json(self):
        return {"record": str(self.path)}


def run(config):
    if config.endswith("/crash.h5"):
        os._exit(9)
    if config.endswith("/killonce.h5"):
        marker = config + ".killed"
        if not os.path.exists(marker):
            open(marker, "w").close()
            os._exit(9)
    if config.endswith("/hog.h5"):
        np.ones(1 << 29)  # 4 GiB, written (not merely reserved)
    if config.endswith("/slow.h5"):
        time.sleep(3.0)
        open(config + ".finished", "w").close()
    with open(config + ".helpers", "w") as f:
        f.write(str(helper_threads()))
    return _Result(config)
