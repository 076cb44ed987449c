"""Helpers both halves of the ROS bag importer share (:mod:`sizefx.importers.rosbag` and
:mod:`sizefx.importers.rosbag_reference`): the row blocks messages' values are collected in, frame
ids, topic names and listings for refusals, and the check that stamps increase."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SourceError
from ..ros import stamp_text

__all__ = ["BLOCK_ROWS", "LISTED", "TF_TOPIC"]

#: The topic of the transforms (tf2 broadcasts there; ``/tf_static`` holds fixed ones, no motion).
TF_TOPIC = "/tf"
#: Rows of one block the messages' values are collected in (2^16 rows of 6 float64: 3 MiB).
BLOCK_ROWS = 1 << 16
#: Topics (and tf frame pairs) a refusal lists before it says how many more there are.
LISTED = 20


def _short(msgtype: str | None) -> str:
    """``sensor_msgs/msg/Imu`` -> ``sensor_msgs/Imu`` (the name users write); None: mixed types."""
    return "(several types)" if msgtype is None else msgtype.replace("/msg/", "/")


def _frame(name) -> str:
    """A frame id as tf2 compares them: without a leading slash (ROS 1's tf_prefix style)."""
    return str(name).lstrip("/")


def _one_value(path: Path, topic: str, index: int, first, value, says: str, first_says: str, rule: str):
    """``value`` of message ``index`` of ``topic`` where the first message gave ``first`` (None: this is
    the first): the first value, or one line saying that message ``index`` differs (a frame of a topic
    that must stay one)."""
    if first is None:
        return value
    if value != first:
        raise SourceError(
            path, f"topic {topic}: message {index} {says} '{value}' and the first {first_says}'{first}'; {rule}"
        )
    return first


def _listing(names: list, more_of: str = "") -> str:
    shown = ", ".join(names[:LISTED]) or "none"
    return shown + (f" and {len(names) - LISTED} more{more_of}" if len(names) > LISTED else "")


class _Rows:
    """Rows of ``width`` float64 values with two int64 stamps (header, receive) each, collected in
    numpy blocks of :data:`BLOCK_ROWS` rows: no Python object per message outlives its message."""

    def __init__(self, width: int):
        self.width = width
        self.values: list[np.ndarray] = []
        self.stamps: list[np.ndarray] = []
        self.n = 0
        self._k = BLOCK_ROWS  # the next row in the last block (full: a new block comes first)

    def add(self, header_ns: int, receive_ns: int, values) -> None:
        if self._k == BLOCK_ROWS:
            self.values.append(np.empty((BLOCK_ROWS, self.width)))
            self.stamps.append(np.empty((BLOCK_ROWS, 2), dtype=np.int64))
            self._k = 0
        self.values[-1][self._k] = values
        self.stamps[-1][self._k] = (header_ns, receive_ns)
        self._k += 1
        self.n += 1

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(stamps [n, 2] int64 ns, values [n, width])``; the blocks are released."""
        if not self.values:
            return np.empty((0, 2), dtype=np.int64), np.empty((0, self.width))
        self.values[-1] = self.values[-1][: self._k]
        self.stamps[-1] = self.stamps[-1][: self._k]
        stamps, values = np.concatenate(self.stamps), np.concatenate(self.values)
        self.values, self.stamps = [], []
        return stamps, values


def _check_order(path: Path, label: str, ns: np.ndarray, stamps: str, what: str = "message") -> None:
    """Stamps strictly increasing in the bag's order, or one line naming the topic, the first
    offending message and its stamps (the telemetry contract's rule for time)."""
    step = np.diff(ns)
    bad = np.flatnonzero(step <= 0)
    if not bad.size:
        return
    k = int(bad[0]) + 1
    if stamps == "header" and not ns.any():
        raise SourceError(
            path, f"topic {label}: every header stamp is zero (the driver does not stamp); import with --stamps receive"
        )
    fix = (
        "import with --stamps receive (the times the recorder received them), or sort and de-duplicate the bag"
        if stamps == "header"
        else "sort and de-duplicate the bag"
    )
    if step[k - 1] == 0:
        count = int(np.count_nonzero(step == 0))
        raise SourceError(
            path,
            f"topic {label}: {stamps} stamps repeat at {what} {k} ({stamp_text(int(ns[k]))}), {count} "
            f"duplicated in all; {fix}",
        )
    count = int(np.count_nonzero(step < 0))
    times = "once" if count == 1 else f"{count} times in all"
    raise SourceError(
        path,
        f"topic {label}: {stamps} stamps go back at {what} {k} ({stamp_text(int(ns[k - 1]))} -> "
        f"{stamp_text(int(ns[k]))}), {times}; {fix}",
    )
