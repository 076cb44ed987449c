"""Hostile inputs for the ``sizefx`` command line: crafted files and option values.

Every case is a command line that a careless or malicious user could type, together with
what the command promises to do with it (``docs/telemetry.md``, ``sizefx --help``):

- exit code 2 for bad input or a bad option (0 where the input is odd but legal);
- exactly one line on stderr, ``sizefx: error: ...``, naming the user's file (or option),
  never a temporary file, never a traceback;
- no output left behind, no ``*.tmp`` file, every input byte-identical afterwards;
- bounded memory and time.

:func:`write_corpus` writes the files, each case into its own folder (so that "the folder
listing is unchanged" is a check of that case alone), and returns the :class:`Case` list.
:func:`run_cases` runs cases (a forked CliRunner, or the installed console script for the
resource cases), :func:`broken_promises` judges one run; ``tests/test_hostile.py`` and
``benchmarks/fuzz_hostile.py`` share all three, so the fuzz and the tests cannot drift apart.

Writing the corpus runs sizefx once, on purpose and on valid input (a 20 s tumble record for
the diagnose cases); every hostile file is written with h5py, json or plain bytes. The module
is long because it is a table of cases; the tables are data, the code around them small.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import re
import resource as _resource
import shutil
import signal
import sys
import time
import traceback as _traceback
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
from support import RATE_HZ, write_raw, write_root_attributes

#: The command exits 2 (bad input or option), with one line.
REFUSE = (2,)
#: The input is odd but legal: the command may run (0) or refuse (2), never anything else.
ACCEPT_OR_REFUSE = (0, 2)
#: A valid input: the command must run. These baselines keep the suite honest: a runner that
#: refused everything would fail them.
ACCEPT = (0,)

#: Rows of the gzip bomb: 2e8 rows x 3 float64 = 4.8 GB of zeros behind ~5 MB on disk. Written
#: chunk by chunk with ``write_direct_chunk`` from one pre-compressed chunk, so making it takes
#: well under a second; lower it (``write_corpus(..., bomb_rows=...)``) on a small disk.
BOMB_ROWS = 200_000_000
#: Rows of each bomb chunk: 2**20 x 3 float64 = 24 MiB decompressed, ~24 kB compressed.
BOMB_CHUNK_ROWS = 1 << 20
#: Declared (never written) rows of the "huge declared shape" case: 10**10 x 3 float64 = 240 GB.
HUGE_DECLARED_ROWS = 10**10
#: Depth of the nested-group case (HDF5 allows it; a recursive walker hits Python's limit at 1000).
DEEP_GROUPS = 2000
#: Depth of the nested TOML/JSON documents: far past Python's recursion limit (1000), so a
#: recursive-descent parser (json, tomllib) that does not guard it raises RecursionError.
DEEP_DOCUMENT = 100_000


@dataclass(frozen=True)
class Case:
    """One hostile command line and its promises.

    Attributes
    ----------
    name : str
        Unique, ``pytest -k`` friendly: ``<kind>-<command>``.
    argv : tuple of str
        Arguments after ``sizefx``.
    folder : Path
        The case's own folder; after a refusal its listing must be as before.
    kept : tuple of Path
        Files that must be byte-identical afterwards: the inputs, and existing files the
        command must not replace.
    expect : tuple of int
        Allowed exit codes (:data:`REFUSE`, :data:`ACCEPT_OR_REFUSE`, :data:`ACCEPT`).
    names : tuple of str
        The error line must contain at least one of these (the user's file, or the option).
    resource : bool
        A memory bomb, a hang candidate or a signal case: run as a subprocess of the installed
        console script, its peak RSS measured.
    skip : str or None
        Why the case cannot be run here (e.g. permissions do not bind root).
    watch : tuple of Path
        Further folders whose listing must not change on a refusal (outputs outside ``folder``).
    """

    name: str
    argv: tuple
    folder: Path
    kept: tuple = ()
    expect: tuple = REFUSE
    names: tuple = ()
    resource: bool = False
    skip: str | None = None
    watch: tuple = field(default_factory=tuple)


# --------------------------------------------------------------------------- valid inputs


def _levers_doc():
    """A valid ``sizefx/levers/1`` document: the paper's high-precision arms, from the rotation centre."""
    d = 0.0249  # m, the high-precision preset's arm
    return {
        "schema": "sizefx/levers/1",
        "reference_point": "rotation-center",
        "r_x": [d, 0.0, 0.0],
        "r_y": [0.0, d, 0.0],
        "r_z": [0.0, 0.0, d],
        "sigma_x": None,
        "sigma_y": None,
        "sigma_z": None,
        "offset": [0.0, 0.0, 0.0],
        "d_x": [d, 0.0, 0.0],
        "d_y": [0.0, d, 0.0],
        "d_z": [0.0, 0.0, d],
        "tilt_arcsec": None,
        "accel_delay_s": None,
    }


VALID_EFFECTS_TOML = """schema = "sizefx/effects/1"

[accel_bias]
enabled = true
bias_ug = [30.0, -20.0, 50.0]
"""


def _csv_text(n=200, rate_hz=RATE_HZ, time_scale=1.0):
    """A static record as CSV: time [s, times ``time_scale``], gyro [rad/s], accel [m/s^2]."""
    rng = np.random.default_rng(2)
    lines = ["t,gx,gy,gz,ax,ay,az"]
    for k in range(n):
        w = np.array([3.9e-5, 0.0, -6.2e-5]) + 1e-6 * rng.standard_normal(3)
        f = np.array([0.0, 0.0, -9.817]) + 1e-4 * rng.standard_normal(3)
        lines.append(",".join(f"{v:.9g}" for v in (k / rate_hz * time_scale, *w, *f)))
    return "\n".join(lines) + "\n"


CSV_OPTIONS = ("--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az", "--site-deg", "57.9825,55.7089,120")


# --------------------------------------------------------------------------- HDF5 breakers
# Each takes the open h5py.File of a valid record (tests/support.py::write_raw) and breaks it
# in one way. The value is (mutate, expected exit codes of inspect, of navigate).


def _set(name, fn):
    def mutate(h5):
        data = h5[name][()]
        units = h5[name].attrs.get("units")
        data = fn(data)
        del h5[name]
        ds = h5.create_dataset(name, data=data)
        if units is not None:
            ds.attrs["units"] = units

    return mutate


def _poke(name, index, value):
    def fn(a):
        a = np.array(a)
        a[index] = value
        return a

    return _set(name, fn)


def _replace(name, data, units=None):
    def mutate(h5):
        old_units = h5[name].attrs.get("units")
        del h5[name]
        ds = h5.create_dataset(name, data=data)
        u = units if units is not None else old_units
        if u is not None:
            ds.attrs["units"] = u

    return mutate


def _attr(obj, key, value):
    def mutate(h5):
        if value is _DELETE:
            del h5[obj].attrs[key]
        else:
            h5[obj].attrs[key] = value

    return mutate


_DELETE = object()


def _soft_cycle_gyro(h5):
    del h5["imu/gyro"]
    h5["imu/gyro"] = h5py.SoftLink("/imu/gyro_b")
    h5["imu/gyro_b"] = h5py.SoftLink("/imu/gyro")


def _soft_cycle_extra(h5):
    h5.create_group("extra")
    h5["extra/a"] = h5py.SoftLink("/extra/b")
    h5["extra/b"] = h5py.SoftLink("/extra/a")
    h5["imu/root"] = h5py.SoftLink("/")


def _hard_cycle(h5):
    sub = h5.create_group("imu/sub")
    sub["up"] = h5["imu"]  # a hard link to the parent: /imu/sub/up/sub/up/... without end
    h5["reference"]["self"] = h5["reference"]


def _deep_groups(h5):
    h5.create_group("imu/" + "/".join(["g"] * DEEP_GROUPS))


def _external_link(h5):
    del h5["imu/gyro"]
    h5["imu/gyro"] = h5py.ExternalLink("/etc/passwd", "/gyro")


def _external_storage(h5):
    n = h5["imu/time"].shape[0]
    units = h5["imu/gyro"].attrs["units"]
    del h5["imu/gyro"]
    # raw data in another file: a telemetry file must not make sizefx read other files
    ds = h5.create_dataset("imu/gyro", shape=(n, 3), dtype="f8", external=[("/dev/zero", 0, n * 24)])
    ds.attrs["units"] = units


def _ref_velocity(value):
    def mutate(h5):
        m = h5["reference/time"].shape[0]
        h5.create_dataset("reference/velocity", data=np.full((m, 3), value)).attrs["units"] = "m/s"

    return mutate


def _ref_position(lat_deg):
    def mutate(h5):
        m = h5["reference/time"].shape[0]
        pos = np.tile([lat_deg, 55.7089, 120.0], (m, 1))
        h5.create_dataset("reference/position", data=pos).attrs["units"] = "deg,deg,m"

    return mutate


def _accel_time(fn):
    def mutate(h5):
        t = h5["imu/time"][()]
        h5.create_dataset("imu/accel_time", data=fn(t)).attrs["units"] = "s"

    return mutate


def _time_is_group(h5):
    """/imu/time a group where a dataset belongs (the whole reader sizes its read from it first)."""
    del h5["imu/time"]
    h5.create_group("imu/time")


def _imu_is_dataset(h5):
    del h5["imu"]
    h5.create_dataset("imu", data=np.zeros((10, 3)))


def _strings(name):
    def mutate(h5):
        shape = h5[name].shape
        units = h5[name].attrs["units"]
        del h5[name]
        data = np.full(shape, "abc", dtype=object)
        h5.create_dataset(name, data=data, dtype=h5py.string_dtype()).attrs["units"] = units

    return mutate


def _simulation_truth(text):
    """A /simulation group whose truth_json attribute is ``text`` (the reader parses it)."""

    def mutate(h5):
        g = h5.create_group("simulation")
        g.attrs["truth_json"] = text

    return mutate


#: Text that is not UTF-8 (Latin-1 "café", then bytes no encoding starts with), stored where HDF5 is
#: told it is UTF-8: HDF5 does not check, and h5py hands it over as lone surrogates.
NOT_UTF8 = b"caf\xe9 \xff\xfe"


def _text_not_utf8(obj, key):
    """Attribute ``key`` of ``obj`` (a group made if missing) holding :data:`NOT_UTF8` as UTF-8 text;
    ``key`` as bytes gives an attribute whose name is not UTF-8."""

    def mutate(h5):
        target = h5[obj] if obj in h5 else h5.create_group(obj)
        target.attrs.create(key, data=NOT_UTF8, dtype=h5py.string_dtype("utf-8"))

    return mutate


def _group_named_not_utf8(h5):
    h5.create_group(b"extra" + NOT_UTF8)


#: Rows of the many-gaps case: a gap after every third sample gives 110 000 gaps, above the
#: reader's 100 000.
MANY_GAPS_ROWS = 330_000
#: Depth of the nested truth_json: past Python's recursion limit (1000), inside an HDF5 attribute
#: (40 kB; compact attributes are limited to 64 kB).
DEEP_ATTRIBUTE_JSON = 20_000


HDF5_BREAKERS = {
    # JSON inside an attribute: parsed by the reader, so bounded like a JSON file
    "simulation-truth-deep": (_simulation_truth("[" * DEEP_ATTRIBUTE_JSON + "]" * DEEP_ATTRIBUTE_JSON), REFUSE, REFUSE),
    "simulation-truth-huge-int": (_simulation_truth('{"seed": 1' + "0" * 5000 + "}"), REFUSE, REFUSE),
    # links and structure
    "soft-link-cycle-gyro": (_soft_cycle_gyro, REFUSE, REFUSE),
    "soft-link-cycle-extra": (_soft_cycle_extra, ACCEPT_OR_REFUSE, ACCEPT_OR_REFUSE),
    "hard-link-cycle": (_hard_cycle, ACCEPT_OR_REFUSE, ACCEPT_OR_REFUSE),
    "deep-groups-2000": (_deep_groups, ACCEPT_OR_REFUSE, ACCEPT_OR_REFUSE),
    "external-link-gyro": (_external_link, REFUSE, REFUSE),
    "external-storage-gyro": (_external_storage, REFUSE, REFUSE),
    "imu-is-a-dataset": (_imu_is_dataset, REFUSE, REFUSE),
    "imu-time-is-a-group": (_time_is_group, REFUSE, REFUSE),
    "schema-attr-missing": (_attr("/", "schema", _DELETE), REFUSE, REFUSE),
    "schema-attr-other": (_attr("/", "schema", "sizefx/telemetry/99"), REFUSE, REFUSE),
    # time axes
    "time-last-stamp-zero": (_poke("imu/time", -1, 0.0), REFUSE, REFUSE),
    "time-non-monotonic": (_set("imu/time", lambda t: np.concatenate([t[:500], t[500:][::-1]])), REFUSE, REFUSE),
    "time-one-step-back": (_poke("imu/time", 500, 4.0), REFUSE, REFUSE),
    "time-duplicated": (_poke("imu/time", 500, 4.99), REFUSE, REFUSE),
    "time-nan": (_poke("imu/time", 500, np.nan), REFUSE, REFUSE),
    "time-inf": (_poke("imu/time", -1, np.inf), REFUSE, REFUSE),
    "time-1e300-last": (_poke("imu/time", -1, 1e300), REFUSE, REFUSE),
    "accel-time-decreasing": (_accel_time(lambda t: t[::-1].copy()), REFUSE, REFUSE),
    "accel-time-last-zero": (_accel_time(lambda t: np.concatenate([t[:-1], [0.0]])), REFUSE, REFUSE),
    "accel-time-nan": (_accel_time(lambda t: np.where(np.arange(t.size) == 7, np.nan, t)), REFUSE, REFUSE),
    # samples
    "accel-nan": (_poke("imu/accel", (500, 1), np.nan), REFUSE, REFUSE),
    "accel-inf": (_poke("imu/accel", (500, 2), np.inf), REFUSE, REFUSE),
    "accel-minus-inf": (_poke("imu/accel", (0, 0), -np.inf), REFUSE, REFUSE),
    "accel-1e300": (_poke("imu/accel", (500, 0), 1e300), REFUSE, REFUSE),
    "gyro-nan": (_poke("imu/gyro", (999, 2), np.nan), REFUSE, REFUSE),
    "gyro-inf": (_poke("imu/gyro", (3, 1), np.inf), REFUSE, REFUSE),
    "gyro-1e300": (_poke("imu/gyro", (500, 0), 1e300), REFUSE, REFUSE),
    "gyro-all-1e300": (_set("imu/gyro", lambda a: np.full_like(a, 1e300)), REFUSE, REFUSE),
    "quaternion-nan": (_poke("reference/quaternion", (5, 0), np.nan), REFUSE, REFUSE),
    "quaternion-zero": (_poke("reference/quaternion", 5, 0.0), REFUSE, REFUSE),
    # hypothesis found it: a 1e288 component is refused, after numpy's overflow warnings on stderr
    "quaternion-1e300": (_poke("reference/quaternion", (5, 1), 1e300), REFUSE, REFUSE),
    "reference-velocity-1e30": (_ref_velocity(1e30), REFUSE, REFUSE),
    "reference-velocity-nan": (_ref_velocity(np.nan), REFUSE, REFUSE),
    "reference-position-lat-100": (_ref_position(100.0), REFUSE, REFUSE),
    # site attributes
    # a pole is outside the contract (the NED longitude rate diverges): refused, naming the attribute
    "latitude-plus-90": (_attr("/", "latitude_deg", 90.0), REFUSE, REFUSE),
    "latitude-minus-90": (_attr("/", "latitude_deg", -90.0), REFUSE, REFUSE),
    "reference-position-lat-90": (_ref_position(90.0), REFUSE, REFUSE),
    "latitude-91": (_attr("/", "latitude_deg", 91.0), REFUSE, REFUSE),
    "latitude-nan": (_attr("/", "latitude_deg", np.nan), REFUSE, REFUSE),
    "latitude-inf": (_attr("/", "latitude_deg", np.inf), REFUSE, REFUSE),
    "latitude-string": (_attr("/", "latitude_deg", "north"), REFUSE, REFUSE),
    "latitude-array": (_attr("/", "latitude_deg", np.array([1.0, 2.0])), REFUSE, REFUSE),
    "longitude-1e300": (_attr("/", "longitude_deg", 1e300), REFUSE, REFUSE),
    "height-1e30": (_attr("/", "height_m", 1e30), REFUSE, REFUSE),
    # units
    "gyro-units-unknown": (_attr("imu/gyro", "units", "furlong/fortnight"), REFUSE, REFUSE),
    "gyro-units-missing": (_attr("imu/gyro", "units", _DELETE), REFUSE, REFUSE),
    "gyro-units-integer": (_attr("imu/gyro", "units", 5), REFUSE, REFUSE),
    "gyro-units-array": (_attr("imu/gyro", "units", np.array([b"rad/s", b"deg/s"])), REFUSE, REFUSE),
    "time-units-ms": (_attr("imu/time", "units", "ms"), REFUSE, REFUSE),
    "accel-units-g-on-m-s2-data": (_attr("imu/accel", "units", "g"), REFUSE, REFUSE),
    # text attributes that are not UTF-8: the informational ones (a description, /source provenance) are
    # carried with backslash escapes; the ones sizefx interprets, and an object name it cannot open, refused
    "description-not-utf8": (_text_not_utf8("/", "description"), ACCEPT, ACCEPT),
    "source-comment-not-utf8": (_text_not_utf8("source", "comment"), ACCEPT, ACCEPT),
    "source-attribute-name-not-utf8": (_text_not_utf8("source", b"note" + NOT_UTF8), ACCEPT, ACCEPT),
    "gyro-units-not-utf8": (_text_not_utf8("imu/gyro", "units"), REFUSE, REFUSE),
    "schema-not-utf8": (_text_not_utf8("/", "schema"), REFUSE, REFUSE),
    "simulation-truth-not-utf8": (_text_not_utf8("simulation", "truth_json"), REFUSE, REFUSE),
    "group-name-not-utf8": (_group_named_not_utf8, REFUSE, REFUSE),
    # dtypes and shapes
    "gyro-strings": (_strings("imu/gyro"), REFUSE, REFUSE),
    "time-strings": (_strings("imu/time"), REFUSE, REFUSE),
    "gyro-int32": (_set("imu/gyro", lambda a: a.astype(np.int32)), REFUSE, REFUSE),
    "gyro-complex": (_set("imu/gyro", lambda a: a.astype(np.complex128)), REFUSE, REFUSE),
    "gyro-float16": (_set("imu/gyro", lambda a: a.astype(np.float16)), REFUSE, REFUSE),
    "gyro-shape-n-2": (_set("imu/gyro", lambda a: a[:, :2].copy()), REFUSE, REFUSE),
    "gyro-shape-n": (_set("imu/gyro", lambda a: a[:, 0].copy()), REFUSE, REFUSE),
    "gyro-shape-n-3-1": (_set("imu/gyro", lambda a: a[:, :, None].copy()), REFUSE, REFUSE),
    "gyro-one-row-short": (_set("imu/gyro", lambda a: a[:-1].copy()), REFUSE, REFUSE),
    "gyro-empty": (_replace("imu/gyro", np.zeros((0, 3))), REFUSE, REFUSE),
    "time-scalar": (_replace("imu/time", np.float64(1.0)), REFUSE, REFUSE),
}

#: Breakers whose record is valid but for text sizefx carries into what it writes (compensate copies the
#: description and /source into its output): that command must run too.
CARRIED_TEXT_KINDS = ("description-not-utf8", "source-comment-not-utf8", "source-attribute-name-not-utf8")

#: Breakers also fed to the commands that read a record in other ways (compensate's
#: accelerometer re-stamping, calibrate's and diagnose's reference use, compare's reader).
CONSUMER_KINDS = (
    "accel-time-decreasing",
    "accel-nan",
    "gyro-1e300",
    "time-last-stamp-zero",
    "reference-velocity-1e30",
    "quaternion-zero",
    "soft-link-cycle-gyro",
    "gyro-shape-n-2",
)


# --------------------------------------------------------------------------- document breakers


def _deep_json():
    return ("[" * DEEP_DOCUMENT + "]" * DEEP_DOCUMENT).encode()


def _levers_with(**changes):
    doc = _levers_doc()
    doc.update(changes)
    return json.dumps(doc).encode()


LEVERS_BREAKERS = {
    "json-deep-array-100000": (_deep_json(), REFUSE),
    "json-deep-object-100000": (('{"a":' * DEEP_DOCUMENT + "1" + "}" * DEEP_DOCUMENT).encode(), REFUSE),
    "json-invalid-utf8": (b'\xff\xfe{"schema": "sizefx/levers/1\xc3\x28"}', REFUSE),
    "json-empty": (b"", REFUSE),
    "json-top-level-list": (b"[1, 2, 3]", REFUSE),
    "json-huge-float": (_levers_with(r_x=[0.0249, 0.0, 0.0]).replace(b"0.0249", b"1e400", 1), REFUSE),
    "json-huge-int": (_levers_with(r_x=[0.0249, 0.0, 0.0]).replace(b"0.0249", b"1" + b"0" * 5000, 1), REFUSE),
    "json-nan": (_levers_with().replace(b"0.0249", b"NaN", 1), REFUSE),
    "json-infinity": (_levers_with().replace(b"0.0249", b"-Infinity", 1), REFUSE),
    "json-arm-1e300": (_levers_with(r_x=[1e300, 0.0, 0.0], d_x=[1e300, 0.0, 0.0]), REFUSE),
    "json-arm-string": (_levers_with(r_x=["a", "b", "c"]), REFUSE),
    "json-arm-two-numbers": (_levers_with(r_y=[0.0, 0.02]), REFUSE),
    "json-bool-for-number": (_levers_with(accel_delay_s=True), REFUSE),
    "json-delay-1e300": (_levers_with(accel_delay_s=1e300), REFUSE),
    "json-tilt-nan-string": (_levers_with(tilt_arcsec=["nan", "inf"]), REFUSE),
    "json-wrong-schema": (_levers_with(schema="sizefx/levers/999"), REFUSE),
    "json-binary-garbage": (bytes(range(256)) * 40, REFUSE),
}


TOML_BREAKERS = {
    "toml-deep-array-100000": (b'schema = "sizefx/effects/1"\nx = ' + _deep_json() + b"\n", REFUSE),
    "toml-deep-inline-table-100000": (b"x = " + b"{a = " * DEEP_DOCUMENT + b"1" + b"}" * DEEP_DOCUMENT + b"\n", REFUSE),
    "toml-deep-dotted-key-100000": (b"[" + b".".join([b"a"] * DEEP_DOCUMENT) + b"]\nx = 1\n", REFUSE),
    "toml-invalid-utf8": (b'schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true # \xff\xfe\n', REFUSE),
    "toml-not-toml": (b"this is not = = toml [\n", REFUSE),
    "toml-binary-garbage": (bytes(range(256)) * 40, REFUSE),
    "toml-huge-int": (
        b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = true\ntau_s = 1' + b"0" * 5000 + b"\n",
        REFUSE,
    ),
    "toml-huge-float": (b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = true\ntau_s = 1e400\n', REFUSE),
    "toml-nan": (b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = true\ntau_s = nan\n', REFUSE),
    "toml-inf-in-vector": (
        b'schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true\nbias_ug = [inf, 0.0, 0.0]\n',
        REFUSE,
    ),
    "toml-1e300-bias": (
        b'schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true\nbias_ug = [1e300, 0.0, 0.0]\n',
        REFUSE,
    ),
    "toml-string-for-number": (b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = true\ntau_s = "fast"\n', REFUSE),
    "toml-string-for-bool": (b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = "yes"\n', REFUSE),
    "toml-vector-two-numbers": (
        b'schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true\nbias_ug = [1.0, 2.0]\n',
        REFUSE,
    ),
    "toml-vector-mixed-types": (
        b'schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true\nbias_ug = [1.0, "x", {a = 1}]\n',
        REFUSE,
    ),
    "toml-section-is-a-number": (b'schema = "sizefx/effects/1"\naccel_bias = 3\n', REFUSE),
    "toml-unknown-section": (b'schema = "sizefx/effects/1"\n[warp_drive]\nenabled = true\n', REFUSE),
    "toml-wrong-schema": (b'schema = "sizefx/effects/99"\n', REFUSE),
    "toml-datetime-for-number": (
        b'schema = "sizefx/effects/1"\n[accel_delay]\nenabled = true\ntau_s = 1979-05-27T07:32:00Z\n',
        REFUSE,
    ),
}


CSV_BREAKERS = {
    "csv-missing-column": (lambda: _csv_text().replace("az", "zz", 1), REFUSE),
    "csv-header-only": (lambda: "t,gx,gy,gz,ax,ay,az\n", REFUSE),
    "csv-one-row": (lambda: _csv_text(n=1), REFUSE),
    "csv-two-rows": (lambda: _csv_text(n=2), ACCEPT_OR_REFUSE),  # as legal as samples-2-inspect
    "csv-empty": (lambda: "", REFUSE),
    "csv-nan": (lambda: _replace_cell(_csv_text(), 50, 4, "nan"), REFUSE),
    "csv-inf": (lambda: _replace_cell(_csv_text(), 50, 1, "inf"), REFUSE),
    "csv-1e300": (lambda: _replace_cell(_csv_text(), 50, 6, "1e300"), REFUSE),
    "csv-1e400": (lambda: _replace_cell(_csv_text(), 50, 6, "1e400"), REFUSE),
    "csv-text-cell": (lambda: _replace_cell(_csv_text(), 50, 2, "hello"), REFUSE),
    "csv-non-monotonic": (lambda: _replace_cell(_csv_text(), 100, 0, "0.2"), REFUSE),
    "csv-duplicated-time": (lambda: _replace_cell(_csv_text(), 100, 0, "0.98"), REFUSE),
    "csv-ragged-row": (lambda: _csv_text().replace("\n", "\n1,2\n", 30).replace("\n1,2\n", "\n", 29), REFUSE),
    "csv-semicolons": (lambda: _csv_text().replace(",", ";"), REFUSE),
    "csv-invalid-utf8": (lambda: _csv_text().encode()[:200] + b"\xff\xfe\xc3\x28" + _csv_text().encode()[200:], REFUSE),
    "csv-binary-garbage": (lambda: bytes(range(256)) * 40, REFUSE),
    # a time column in milliseconds read as seconds (the default --time-units s): 0.1 Hz, not 100 Hz
    "csv-time-in-ms-read-as-s": (lambda: _csv_text(time_scale=1e3), REFUSE),
    "csv-10MB-field": (lambda: "t,gx,gy,gz,ax,ay,az\n" + "1" * 10_000_000 + ",0,0,0,0,0,-9.8\n", REFUSE),
}


def _csv_reference_text(lat_deg=57.9825, n=20, rate_hz=RATE_HZ / 10, time_scale=1.0):
    """A reference CSV for :func:`_csv_text`'s static record: level (identity quaternion, body = NED),
    at latitude ``lat_deg``: time [s, times ``time_scale``], quaternion, latitude [deg], longitude [deg],
    height [m]."""
    lines = ["t,qw,qx,qy,qz,lat,lon,h"]
    lines += [f"{k / rate_hz * time_scale:.9g},1,0,0,0,{lat_deg:.9g},55.7089,120" for k in range(n)]
    return "\n".join(lines) + "\n"


#: The options that import :func:`_csv_reference_text` as ``--reference-file``.
CSV_REFERENCE_OPTIONS = ("--reference-quaternion", "qw,qx,qy,qz", "--reference-position", "lat,lon,h")


def _replace_cell(text, row, col, value):
    lines = text.split("\n")
    cells = lines[row + 1].split(",")
    cells[col] = value
    lines[row + 1] = ",".join(cells)
    return "\n".join(lines)


# --------------------------------------------------------------------------- numeric options

#: A small, valid command line for each command whose numeric options are fuzzed: when a
#: hostile value happens to be legal the run must still finish in seconds. ``{rec}`` is a valid
#: record, ``{tumble}`` a tumble record (what diagnose needs), ``{csv}`` a valid CSV,
#: ``{levers}`` a levers file, ``{out}`` the output.
BASES = {
    (
        "simulate",
        "turntable",
    ): "-o {out} -q --rate-hz 100 --vertical-axes Z --cycles 1 --seconds-per-axis 24 --static-s 1",
    ("simulate", "sway"): "-o {out} -q --rate-hz 100 --static-s 1 --segment-s 2 --amplitudes-dps 10",
    ("simulate", "flight"): "-o {out} -q --rate-hz 50 --reference-rate-hz 10 --duration-h 0.3 --align-s 10",
    ("simulate", "tumble"): "-o {out} -q --rate-hz 100 --duration-s 2",
    ("navigate",): "{rec} -o {out} -q",
    ("compensate",): "{rec} --levers {levers} -o {out}",
    ("diagnose",): "{tumble} --json {out} --model-out {out2} --no-navigation",
    ("import", "csv"): "{csv} -o {out} " + " ".join(CSV_OPTIONS),
}

#: Options whose value must be positive (a rate, a duration, a count, a seed numpy accepts):
#: -1 must be refused.
POSITIVE = {
    "--rate-hz",
    "--reference-rate-hz",
    "--duration-h",
    "--duration-s",
    "--seconds-per-axis",
    "--static-s",
    "--segment-s",
    "--frequency-hz",
    "--accel-dps2",
    "--speed-mps",
    "--align-s",
    "--output-rate-hz",
    "--bandwidth-hz",
    "--rotor-hz",
    "--cycles",
    "--subsamples",
    "--chunk-samples",
    "--segment",
    "--seed",
}
#: Positive options where 0 has a documented meaning or is harmless: every navigation interval
#: (``--output-rate-hz 0``), the whole record (``--chunk-samples 0``), no static lead-in, seed 0.
ZERO_LEGAL = {"--output-rate-hz", "--chunk-samples", "--static-s", "--seed", "--align-s"}
#: Options where 1e308 (or 10**30) can be honoured or clamped (an end time past the record,
#: a chunk larger than the record, a seed, an angle, a rate above the navigation rate):
#: accept or refuse. Everywhere else 1e308 cannot be honoured in bounded time and memory or is
#: outside the contract's ranges, so it must be refused.
HUGE_LEGAL = {"--to-s", "--chunk-samples", "--seed", "--heading-deg", "--output-rate-hz", "--bandwidth-hz"}


def numeric_options():
    """Every FLOAT/INT option of every command in :data:`BASES`, by click introspection:
    ``[(command path, option flag, 'float' or 'int')]``."""
    import click

    from sizefx_cli.main import main

    found = []
    for path in BASES:
        cmd = main
        for part in path:
            cmd = cmd.commands[part]
        for p in cmd.params:
            if not isinstance(p, click.Option) or p.is_flag:
                continue
            if isinstance(p.type, (click.types.FloatParamType, click.FloatRange)):
                found.append((path, p.opts[-1] if p.opts[-1].startswith("--") else p.opts[0], "float"))
            elif isinstance(p.type, (click.types.IntParamType, click.IntRange)):
                found.append((path, next(o for o in p.opts if o.startswith("--")), "int"))
    return found


def option_expectation(flag, value: str):
    """What a numeric option must do with ``value``: non-finite values are always refused."""
    low = value.lower().lstrip("+-")
    if low in ("nan", "inf", "infinity") or "nan" in low:
        return REFUSE
    try:
        x = float(value)
    except ValueError:
        return REFUSE
    if x != x or abs(x) == float("inf"):
        return REFUSE
    if x < 0 and flag in POSITIVE:
        return REFUSE
    if x == 0 and flag in POSITIVE and flag not in ZERO_LEGAL:
        return REFUSE
    if abs(x) >= 1e300 and flag not in HUGE_LEGAL:
        return REFUSE
    return ACCEPT_OR_REFUSE


#: Values every numeric option is given: non-finite (always refused), beyond any physical
#: need, negative, zero and a subnormal-scale positive (divisions by them; hypothesis found
#: ``simulate flight --align-s 0`` ending in a traceback).
FLOAT_VALUES = ("nan", "inf", "-inf", "1e308", "-1", "0", "1e-300")
INT_VALUES = ("nan", "-1", "0", "1" + "0" * 30)
#: The values that only test an option that must be positive.
SIGN_VALUES = ("-1", "0", "1e-300")


# --------------------------------------------------------------------------- the writer


class _Folder:
    """One case folder with its shared valid inputs copied in (each case owns its files)."""

    def __init__(self, root: Path, templates: dict):
        self.root = root
        self.templates = templates

    def new(self, name):
        folder = self.root / name
        folder.mkdir(parents=True)
        return folder

    def copy(self, folder, key, name=None):
        src = self.templates[key]
        dst = folder / (name or src.name)
        shutil.copyfile(src, dst)
        return dst


def _templates(root: Path):
    """The valid inputs every case starts from, written once and copied into the case folders."""
    t = root / "_valid"
    t.mkdir(parents=True)
    rec = write_raw(t / "rec.h5")
    lev = t / "levers.json"
    lev.write_text(json.dumps(_levers_doc(), indent=1))
    model = t / "model.toml"
    model.write_text(VALID_EFFECTS_TOML)
    csv = t / "log.csv"
    csv.write_text(_csv_text())
    from sizefx import scenarios
    from sizefx.simulate import SimulateConfig, run  # the one sizefx call: a valid tumble record for diagnose

    tumble = t / "tumble.h5"
    run(SimulateConfig("tumble", str(tumble), plan=scenarios.TumblePlan(duration_s=20.0), rate_hz=100.0, seed=0))
    return {"rec": rec, "levers": lev, "model": model, "csv": csv, "tumble": tumble}


def option_case(root, path, flag, value, name) -> Case:
    """One numeric-option case built from the valid inputs of a corpus already written under
    ``root`` (for hypothesis, which draws the option and the value)."""
    root = Path(root)
    valid = root / "_valid"
    f = _Folder(
        root,
        {
            "rec": valid / "rec.h5",
            "levers": valid / "levers.json",
            "model": valid / "model.toml",
            "csv": valid / "log.csv",
            "tumble": valid / "tumble.h5",
        },
    )
    d = f.new(name)
    argv, kept = _fill(tuple(path), d, f)
    return Case(name, argv + (flag, value), d, tuple(kept), option_expectation(flag, value), (flag,))


def record_case(root, name, mutate, command, expect) -> Case:
    """One mutated valid record (``write_raw(mutate=...)``) fed to ``inspect`` or ``navigate``."""
    d = Path(root) / name
    d.mkdir(parents=True)
    rec = write_raw(d / "rec.h5", mutate=mutate)
    argv = ("inspect", str(rec)) if command == "inspect" else _nav(rec, d)
    return Case(name, argv, d, (rec,), expect, (str(rec),))


#: Datasets a value mutation may hit, with the rows ``write_raw`` gives them.
MUTATION_TARGETS = {"imu/time": 1000, "imu/gyro": 1000, "imu/accel": 1000, "reference/quaternion": 100}


def mutation_expectation(dataset, row, value):
    """Non-finite anywhere, or a time stamp out of order, must be refused; anything else may
    be accepted (a 1e30 accelerometer sample is refused by a good reader but not required to)."""
    if not np.isfinite(value):
        return REFUSE
    if dataset == "imu/time":
        t = np.arange(MUTATION_TARGETS[dataset]) / RATE_HZ
        t[row] = value
        if np.any(np.diff(t) <= 0):
            return REFUSE
    return ACCEPT_OR_REFUSE


def mutated_value_case(root, name, dataset, row, col, value, command) -> Case:
    """A valid record with one value of ``dataset`` replaced, fed to ``command``."""
    row = row % MUTATION_TARGETS[dataset]

    def mutate(h5):
        a = h5[dataset][()]
        if a.ndim == 1:
            a[row] = value
        else:
            a[row, col % a.shape[1]] = value
        h5[dataset][...] = a

    return record_case(root, name, mutate, command, mutation_expectation(dataset, row, value))


def byte_flip_case(root, name, rng, kind) -> Case:
    """A valid input (``kind``: rec, levers, model or csv, from ``root/_valid``) with a few random
    bytes overwritten: the command may accept it or refuse it, within every other promise."""
    valid = Path(root) / "_valid"
    src = {
        "rec": valid / "rec.h5",
        "levers": valid / "levers.json",
        "model": valid / "model.toml",
        "csv": valid / "log.csv",
    }[kind]
    d = Path(root) / name
    d.mkdir(parents=True)
    data = bytearray(src.read_bytes())
    for _ in range(int(rng.integers(1, 9))):
        data[int(rng.integers(0, len(data)))] = int(rng.integers(0, 256))
    p = d / src.name
    p.write_bytes(bytes(data))
    rec = valid / "rec.h5"
    if kind == "rec":
        argv, kept = ("inspect", str(p)), (p,)
    elif kind == "csv":
        argv, kept = ("import", "csv", str(p), "-o", str(d / "o.h5"), *CSV_OPTIONS), (p,)
    else:
        local = d / "rec.h5"
        shutil.copyfile(rec, local)
        opt = "--levers" if kind == "levers" else "--model"
        argv, kept = ("compensate", str(local), opt, str(p), "-o", str(d / "c.h5")), (p, local)
    return Case(name, argv, d, kept, ACCEPT_OR_REFUSE, (str(p),))


#: Modules a forked case would otherwise import on its own (diagnose alone takes 1.5 s):
#: imported once in the parent, before any fork.
WARM_IMPORTS = (
    "sizefx.diagnose",
    "sizefx.navigate",
    "sizefx.compensate",
    "sizefx.calibrate",
    "sizefx.compare",
    "sizefx.importers",
    "sizefx.inspect",
    "sizefx.simulate",
    "sizefx.correct",
    "sizefx.scenarios",
    "scipy.signal",
    "scipy.optimize",
    "scipy.stats",
    "scipy.interpolate",
    "scipy.integrate",
    "matplotlib",
    "matplotlib.pyplot",
)


def warm_imports():
    """Import :data:`WARM_IMPORTS` (those that exist) into this process before forking."""
    import importlib

    for name in WARM_IMPORTS:
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        pass


def write_corpus(root, *, bomb_rows: int = BOMB_ROWS, resource: bool = True) -> list:
    """Write every case's files under ``root`` (one folder per case) and return the cases.

    ``resource=False`` leaves out the memory bombs and hang candidates (their files are the
    only slow or large ones).
    """
    root = Path(root)
    f = _Folder(root, _templates(root))
    cases = []
    cases += _baseline_cases(f)
    cases += _hdf5_cases(f)
    cases += _file_kind_cases(f)
    cases += _document_cases(f)
    cases += _csv_cases(f)
    cases += _output_cases(f)
    cases += _plot_cases(f)
    cases += numeric_option_cases(f)
    cases += _fleet_cases(f)
    if resource:
        cases += resource_cases(f, bomb_rows=bomb_rows)
    names = [c.name for c in cases]
    assert len(names) == len(set(names)), "case names must be unique"
    return cases


def _fleet_cases(f):
    """The fleet commands (``sizefx batch``, ``sizefx batch run``, ``sizefx run``) against planted links,
    files that never end, collisions with their own files, bad option files and scheduler addresses
    (docs/reliability.md, "Batches and chains"). Each case's inputs lie in its folder and
    its ``--out`` beside them (watched: a refusal leaves it as it was, absent or empty)."""
    out = []

    def case(name, make, expect=REFUSE, resource=False):
        d = f.new(name)
        inputs = d / "in"
        inputs.mkdir()
        a, b = f.copy(inputs, "rec", "a.h5"), f.copy(inputs, "rec", "b.h5")
        lev = f.copy(d, "levers")
        dest = d / "out"
        argv, names, kept = make(d, inputs, a, b, lev, dest)
        out.append(
            Case(
                f"fleet-{name}", tuple(map(str, argv)), d, (a, b, lev, *kept), expect, tuple(map(str, names)), resource
            )
        )

    def made(dest):
        dest.mkdir()
        return dest

    def out_holds_records(d, inputs, a, b, lev, dest):  # the shell expanded d/*.h5 with --out d
        shutil.copyfile(a, inputs / "a.compensated.h5")
        argv = ("batch", "compensate", a, b, inputs / "a.compensated.h5", "--levers", lev, "--out", inputs)
        return argv, ("--out holds the input",), (inputs / "a.compensated.h5",)

    def output_links_to_input(d, inputs, a, b, lev, dest):
        (made(dest) / "a.inspect.json").symlink_to(b)
        return ("batch", "inspect", inputs, "--out", dest), ("would overwrite",), ()

    def plant(name, how):
        def make(d, inputs, a, b, lev, dest):
            how(made(dest) / name, a)
            return ("batch", "inspect", inputs, "--out", dest), (str(dest / name),), ()

        return make

    def scheduler(address):
        def make(d, inputs, a, b, lev, dest):
            return ("batch", "inspect", inputs, "--out", dest, "--scheduler", address), ("--scheduler",), ()

        return make

    def levers_file(make_file):
        def make(d, inputs, a, b, lev, dest):
            bad = make_file(d)
            return ("batch", "navigate", inputs, "--levers", bad, "--out", dest), (str(bad),), ()

        return make

    def nan_levers(d):
        p = d / "nan.json"
        p.write_text(json.dumps({**_levers_doc(), "r_x": [float("nan"), 0.0, 0.0]}))
        return p

    def fifo(d):
        os.mkfifo(d / "pipe.json")
        return d / "pipe.json"

    def record(path_of):
        def make(d, inputs, a, b, lev, dest):
            rec = path_of(d)
            return ("batch", "inspect", rec, "--out", dest), (str(rec),), ()

        return make

    def fifo_record(d):
        os.mkfifo(d / "pipe.h5")
        return d / "pipe.h5"

    def glob_link_loop(d, inputs, a, b, lev, dest):
        (inputs / "deeper").mkdir()
        (inputs / "deeper" / "up").symlink_to("..")
        (inputs / "deeper" / "upup").symlink_to("../..")
        return ("batch", "inspect", f"{inputs}/**/*.h5", "--out", dest, "--workers", "1"), (), ()

    def out_loop(d, inputs, a, b, lev, dest):
        (d / "l1").symlink_to(d / "l2")
        (d / "l2").symlink_to(d / "l1")
        return ("batch", "inspect", inputs, "--out", d / "l1"), ("--out",), ()

    def flight_named_manifest(d, inputs, a, b, lev, dest):
        shutil.copyfile(a, inputs / "manifest.json.h5")
        argv = ("batch", "run", "--out", dest, "navigate", "--levers", lev, inputs)
        return argv, ("manifest.json",), (inputs / "manifest.json.h5",)

    def chain_bad_flight(d, inputs, a, b, lev, dest):
        text = inputs / "flight.h5"
        text.write_text("not a record")
        return ("run", "--out", dest, "calibrate", a, "navigate", text, "compare"), (str(text),), (text,)

    def garbage_store(d, inputs, a, b, lev, dest):
        (made(dest) / "manifest.sqlite").write_text("not a database " * 100)
        return ("batch", "inspect", inputs, "--out", dest), ("manifest.sqlite",), (dest / "manifest.sqlite",)

    case("out-holds-records", out_holds_records)
    case("output-links-to-input", output_links_to_input)
    case("lock-link-to-record", plant(".sizefx.lock", lambda p, a: p.symlink_to(a)))
    case("lock-dangling-link", plant(".sizefx.lock", lambda p, a: p.symlink_to(p.parent / "nowhere")))
    case("lock-folder", plant(".sizefx.lock", lambda p, a: p.mkdir()))
    case("lock-fifo", plant(".sizefx.lock", lambda p, a: os.mkfifo(p)), resource=True)
    case("manifest-link-to-record", plant("manifest.json", lambda p, a: p.symlink_to(a)))
    case("store-link-to-record", plant("manifest.sqlite", lambda p, a: p.symlink_to(a)))
    case("store-garbage", garbage_store)
    case("record-fifo", record(fifo_record), resource=True)
    case("record-dev-zero", record(lambda d: Path("/dev/zero")), resource=True)
    case("levers-dev-zero", levers_file(lambda d: Path("/dev/zero")), resource=True)
    case("levers-fifo", levers_file(fifo), resource=True)
    case("levers-nan", levers_file(nan_levers))
    case("glob-link-loop", glob_link_loop, expect=ACCEPT, resource=True)
    case("out-empty", lambda d, i, a, b, lev, dest: (("batch", "inspect", i, "--out", ""), ("--out",), ()))
    case("out-link-loop", out_loop)
    case(
        "out-cannot-be-made",
        lambda d, i, a, b, lev, dest: (("batch", "inspect", i, "--out", "/proc/nope"), ("--out",), ()),
    )
    case("run-flight-named-manifest", flight_named_manifest)
    case("run-chain-bad-second-step", chain_bad_flight)
    case("scheduler-empty", scheduler(""))
    case("scheduler-ucx", scheduler("ucx://127.0.0.1:8786"))
    case("scheduler-no-host", scheduler("tcp://"))
    case("scheduler-unreachable", scheduler("tcp://127.0.0.1:9"), resource=True)
    return out


def _nav(rec, folder):
    return ("navigate", str(rec), "-o", str(folder / "nav.h5"), "--json", str(folder / "nav.json"), "-q")


def _baseline_cases(f):
    out = []
    d = f.new("valid-inspect")
    rec = f.copy(d, "rec")
    out.append(Case("valid-inspect", ("inspect", str(rec)), d, (rec,), ACCEPT))
    d = f.new("valid-navigate")
    rec = f.copy(d, "rec")
    out.append(Case("valid-navigate", _nav(rec, d), d, (rec,), ACCEPT))
    d = f.new("valid-compensate-levers")
    rec, lev = f.copy(d, "rec"), f.copy(d, "levers")
    out.append(
        Case(
            "valid-compensate-levers",
            ("compensate", str(rec), "--levers", str(lev), "-o", str(d / "c.h5")),
            d,
            (rec, lev),
            ACCEPT,
        )
    )
    d = f.new("valid-compensate-model")
    rec, model = f.copy(d, "rec"), f.copy(d, "model")
    out.append(
        Case(
            "valid-compensate-model",
            ("compensate", str(rec), "--model", str(model), "-o", str(d / "c.h5")),
            d,
            (rec, model),
            ACCEPT,
        )
    )
    d = f.new("valid-import-csv")
    csv = f.copy(d, "csv")
    out.append(
        Case("valid-import-csv", ("import", "csv", str(csv), "-o", str(d / "o.h5"), *CSV_OPTIONS), d, (csv,), ACCEPT)
    )
    return out


def _hdf5_cases(f):
    out = []
    for kind, (mutate, inspect_expect, nav_expect) in HDF5_BREAKERS.items():
        for command in (
            ("inspect", "navigate")
            + (("compensate", "calibrate", "diagnose", "compare") if kind in CONSUMER_KINDS else ())
            + (("compensate",) if kind in CARRIED_TEXT_KINDS else ())
        ):
            name = f"{kind}-{command}"
            d = f.new(name)
            rec = write_raw(d / "rec.h5", mutate=mutate)
            kept = [rec]
            if command == "inspect":
                argv, expect = ("inspect", str(rec)), inspect_expect
            elif command == "navigate":
                argv, expect = _nav(rec, d), nav_expect
            elif command == "compensate":
                lev = f.copy(d, "levers")
                kept.append(lev)
                argv = ("compensate", str(rec), "--levers", str(lev), "-o", str(d / "c.h5"))
                expect = ACCEPT if kind in CARRIED_TEXT_KINDS else REFUSE
            elif command == "calibrate":
                argv, expect = ("calibrate", str(rec), "--json", str(d / "lev.json")), REFUSE
            elif command == "diagnose":
                argv, expect = ("diagnose", str(rec), "--json", str(d / "d.json"), "--no-navigation"), REFUSE
            else:
                other = f.copy(d, "rec", "other.h5")
                kept.append(other)
                argv, expect = ("compare", str(rec), str(other), "--json", str(d / "cmp.json")), REFUSE
            out.append(Case(name, argv, d, tuple(kept), expect, (str(rec),)))
    # a gap after every third sample: more gaps than any record can have (sizefx.io.contract.validation.MAX_GAPS),
    # refused even with --allow-gaps, before a list of 100 000 gaps is built and reported
    for command in ("inspect", "navigate"):
        name = f"many-gaps-allowed-{command}"
        d = f.new(name)
        steps = np.tile([1.0, 1.0, 3.0], MANY_GAPS_ROWS // 3) / RATE_HZ  # median step 1 period: 3 is a gap
        rec = write_raw(
            d / "rec.h5",
            n=MANY_GAPS_ROWS,
            reference=False,
            mutate=_replace("imu/time", np.concatenate([[0.0], np.cumsum(steps)[:-1]])),
        )
        argv = ("inspect", str(rec)) if command == "inspect" else _nav(rec, d)
        out.append(Case(name, argv + ("--allow-gaps",), d, (rec,), REFUSE, (str(rec),)))
    for n in range(1, 6):
        for command in ("inspect", "navigate"):
            name = f"samples-{n}-{command}"
            d = f.new(name)
            rec = write_raw(d / "rec.h5", n=n, reference=False)
            argv = ("inspect", str(rec)) if command == "inspect" else _nav(rec, d)
            out.append(Case(name, argv, d, (rec,), ACCEPT_OR_REFUSE if command == "inspect" else REFUSE, (str(rec),)))
    return out


def _reader_argv(f, command, rec, d):
    """The command line of ``inspect``, ``navigate`` or ``compensate`` (with a levers file copied into
    ``d``) on record ``rec``, and the extra inputs it reads: ``(argv, (levers,) or ())``."""
    if command == "inspect":
        return ("inspect", str(rec)), ()
    if command == "navigate":
        return _nav(rec, d), ()
    lev = f.copy(d, "levers")
    return ("compensate", str(rec), "--levers", str(lev), "-o", str(d / "c.h5")), (lev,)


def _file_kind_cases(f):
    """Files that are not HDF5 at all, or not files."""
    out = []

    def add(kind, make, commands=("inspect", "navigate", "compensate")):
        for command in commands:
            name = f"{kind}-{command}"
            d = f.new(name)
            rec = make(d)
            argv, extra = _reader_argv(f, command, rec, d)
            out.append(Case(name, argv, d, ((rec,) if rec.is_file() else ()) + extra, REFUSE, (str(rec),)))

    def truncated(fraction):
        def make(d):
            rec = write_raw(d / "rec.h5")
            data = rec.read_bytes()
            rec.write_bytes(data[: int(len(data) * fraction)])
            return rec

        return make

    def text(d):
        p = d / "rec.h5"
        p.write_text("time,gyro,accel\n0,1,2\n")
        return p

    def empty(d):
        p = d / "rec.h5"
        p.write_bytes(b"")
        return p

    def directory(d):
        p = d / "rec.h5"
        p.mkdir()
        return p

    def missing(d):
        return d / "rec.h5"

    def signature_only(d):
        p = d / "rec.h5"
        p.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 1000)
        return p

    add("truncated-half", truncated(0.5))
    add("truncated-2k", lambda d: _truncate_to(write_raw(d / "rec.h5"), 2048))
    add("zero-byte", empty)
    add("text-named-h5", text)
    add("directory-input", directory)
    add("missing-input", missing)
    add("hdf5-signature-then-zeros", signature_only)
    return out


def _truncate_to(path, size):
    data = path.read_bytes()
    path.write_bytes(data[:size])
    return path


def _document_cases(f):
    out = []
    for kind, (data, expect) in LEVERS_BREAKERS.items():
        for command in ("compensate", "navigate", "diagnose-nominal"):
            if command != "compensate" and not kind.startswith(("json-deep", "json-invalid", "json-nan", "json-huge")):
                continue  # every breaker through one reader; the parser-level ones through all three
            name = f"{kind}-{command}"
            d = f.new(name)
            lev = d / "levers.json"
            lev.write_bytes(data)
            if command == "compensate":
                rec = f.copy(d, "rec")
                argv = ("compensate", str(rec), "--levers", str(lev), "-o", str(d / "c.h5"))
            elif command == "navigate":
                rec = f.copy(d, "rec")
                argv = _nav(rec, d)[:2] + ("--levers", str(lev)) + _nav(rec, d)[2:]
            else:
                rec = f.copy(d, "tumble")
                argv = ("diagnose", str(rec), "--nominal", str(lev), "--json", str(d / "d.json"), "--no-navigation")
            out.append(Case(name, argv, d, (rec, lev), expect, (str(lev),)))
    for kind, (data, expect) in TOML_BREAKERS.items():
        for command in ("compensate", "simulate", "navigate", "diagnose"):
            if (
                command in ("navigate", "diagnose")
                and ("deep" not in kind or "dotted" in kind)
                and "utf8" not in kind
                and "huge" not in kind
            ):
                continue  # every breaker through two readers (--model, --effects); parser-level ones through all
            name = f"{kind}-{command}"
            d = f.new(name)
            model = d / "model.toml"
            model.write_bytes(data)
            kept = [model]
            if command == "compensate":
                rec = f.copy(d, "rec")
                kept.append(rec)
                argv = ("compensate", str(rec), "--model", str(model), "-o", str(d / "c.h5"))
            elif command == "simulate":
                argv = (
                    "simulate",
                    "tumble",
                    "-o",
                    str(d / "s.h5"),
                    "-q",
                    "--rate-hz",
                    "100",
                    "--duration-s",
                    "2",
                    "--effects",
                    str(model),
                )
            elif command == "navigate":
                rec = f.copy(d, "rec")
                kept.append(rec)
                argv = _nav(rec, d)[:2] + ("--model", str(model)) + _nav(rec, d)[2:]
            else:
                rec = f.copy(d, "tumble")
                kept.append(rec)
                argv = ("diagnose", str(rec), "--model", str(model), "--json", str(d / "d.json"), "--no-navigation")
            out.append(Case(name, argv, d, tuple(kept), expect, (str(model),)))
    # --set goes through the same TOML value parser
    for kind, value in (
        ("set-nan", "accel_bias.bias_ug=[nan,0,0]"),
        ("set-inf", "accel_delay.tau_s=inf"),
        ("set-1e308", "accel_delay.tau_s=1e308"),
        ("set-1e300-arm", "lever_arm.r0_m=[1e300,0,0]"),
        ("set-deep-array", "accel_bias.bias_ug=" + "[" * 5000 + "]" * 5000),
        ("set-huge-int", "accel_delay.tau_s=1" + "0" * 5000),
    ):
        name = f"{kind}-simulate"
        d = f.new(name)
        argv = (
            "simulate",
            "tumble",
            "-o",
            str(d / "s.h5"),
            "-q",
            "--rate-hz",
            "100",
            "--duration-s",
            "2",
            "--set",
            value,
        )
        out.append(Case(name, argv, d, (), REFUSE, ("--set", value.split("=")[0])))  # or its key: _spellings
    return out


def _csv_cases(f):
    out = []
    for kind, (make, expect) in CSV_BREAKERS.items():
        name = f"{kind}-import"
        d = f.new(name)
        src = d / "log.csv"
        data = make()
        src.write_bytes(data if isinstance(data, bytes) else data.encode())
        argv = ("import", "csv", str(src), "-o", str(d / "o.h5"), *CSV_OPTIONS)
        out.append(Case(name, argv, d, (src,), expect, (str(src),)))
    # a site at a pole, by the option or by the reference file's latitude column: named, with the range
    for kind, site in (("csv-site-deg-north-pole", "90,55.7089,120"), ("csv-site-deg-south-pole", "-90,55.7089,120")):
        name = f"{kind}-import"
        d = f.new(name)
        src = f.copy(d, "csv")
        argv = ("import", "csv", str(src), "-o", str(d / "o.h5"), *CSV_OPTIONS, "--site-deg", site)
        out.append(Case(name, argv, d, (src,), REFUSE, ("--site-deg",)))
    # the reference file's own time column: at a pole, in milliseconds read as seconds; and a valid one
    for name, text, expect in (
        ("csv-reference-latitude-90-import", _csv_reference_text(90.0), REFUSE),
        ("csv-reference-time-in-ms-read-as-s-import", _csv_reference_text(time_scale=1e3), REFUSE),
        ("valid-import-csv-reference", _csv_reference_text(), ACCEPT),
    ):
        d = f.new(name)
        src, ref = f.copy(d, "csv"), d / "ref.csv"
        ref.write_text(text)
        argv = ("import", "csv", str(src), "-o", str(d / "o.h5"), *CSV_OPTIONS, "--reference-file", str(ref))
        out.append(Case(name, argv + CSV_REFERENCE_OPTIONS, d, (src, ref), expect, (str(ref),)))
    d = f.new("csv-samples-without-rate-import")
    src = f.copy(d, "csv")
    out.append(
        Case(
            "csv-samples-without-rate-import",
            ("import", "csv", str(src), "-o", str(d / "o.h5"), *CSV_OPTIONS, "--time-units", "samples"),
            d,
            (src,),
            REFUSE,
            (str(src), "--rate-hz"),
        )
    )
    return out


def _reference_everywhere(h5):
    """A level /reference with position at every IMU sample of a record written without one: navigate
    starts from it, and --plot has the position error to draw."""
    t = h5["imu/time"][()]
    ref = h5.create_group("reference")
    ref.create_dataset("time", data=t).attrs["units"] = "s"
    ref.create_dataset("quaternion", data=np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1)))
    ref.create_dataset("position", data=np.tile([57.9825, 55.7089, 120.0], (t.size, 1))).attrs["units"] = "deg,deg,m"


#: Per command with a plot option: its command line on a record ``rec`` (``other``: a copy, ``lev``: a
#: levers file, ``d``: the case folder), and what it must do with a record of 5 and of 10 samples.
PLOT_COMMANDS = {
    "navigate-plot": (lambda rec, other, lev, d: ("navigate", rec, "--plot", d / "err.png", "-q"), REFUSE, REFUSE),
    "navigate-output": (lambda rec, other, lev, d: ("navigate", rec, "-o", d / "nav.h5", "-q"), REFUSE, ACCEPT),
    "run-plots": (
        lambda rec, other, lev, d: (
            "run",
            "--out",
            d / "run",
            "--with-plots",
            "navigate",
            "--levers",
            lev,
            rec,
            "compare",
        ),
        REFUSE,
        REFUSE,
    ),
    "diagnose-plots": (
        lambda rec, other, lev, d: ("diagnose", rec, "--plots", d / "plots", "--no-navigation"),
        REFUSE,
        REFUSE,
    ),
    "calibrate-plot": (lambda rec, other, lev, d: ("calibrate", rec, "--plot", d / "fig6.png"), REFUSE, REFUSE),
    # two references of a few samples are legal tracks: compared and drawn
    "compare-plots": (
        lambda rec, other, lev, d: ("compare", rec, other, "--plots", d / "plots"),
        ACCEPT_OR_REFUSE,
        ACCEPT_OR_REFUSE,
    ),
}


def _plot_cases(f):
    """A record of a handful of samples given to every command with a plot option: refused in one line
    where there is nothing to draw, run where a tiny record is legal; and a plot asked of a record
    without reference position, refused before the solution is written."""
    out = []
    for n in (5, 10):
        for what, (build, expect_5, expect_10) in PLOT_COMMANDS.items():
            name = f"samples-{n}-{what}"
            d = f.new(name)
            rec = write_raw(d / "rec.h5", n=n, reference=False, mutate=_reference_everywhere)
            other = d / "other.h5"
            shutil.copyfile(rec, other)
            lev = f.copy(d, "levers")
            argv = tuple(str(a) for a in build(rec, other, lev, d))
            out.append(Case(name, argv, d, (rec, other, lev), expect_5 if n == 5 else expect_10, (str(rec),)))
    name = "no-reference-position-navigate-output-and-plot"
    d = f.new(name)
    rec = f.copy(d, "rec")
    argv = ("navigate", str(rec), "-o", str(d / "nav.h5"), "--plot", str(d / "err.png"), "-q")
    out.append(Case(name, argv, d, (rec,), REFUSE, (str(rec),)))
    return out


def _output_cases(f):
    """The output promises: never an input, never two outputs on one path, never half a file."""
    out = []

    def case(name, build, expect=REFUSE, skip=None):
        d = f.new(name)
        argv, kept, names, watch = build(d)
        out.append(Case(name, tuple(argv), d, tuple(kept), expect, tuple(names), skip=skip, watch=tuple(watch)))

    def o_is_input(d):
        rec, lev = f.copy(d, "rec"), f.copy(d, "levers")
        return ["compensate", rec, "--levers", lev, "-o", rec, "--force"], [rec, lev], [str(rec)], []

    def o_is_input_navigate(d):
        rec = f.copy(d, "rec")
        return ["navigate", rec, "-o", rec, "-q", "--force"], [rec], [str(rec)], []

    def o_and_json_same(d):
        rec = f.copy(d, "rec")
        return ["navigate", rec, "-o", d / "x.out", "--json", d / "x.out", "-q"], [rec], [str(d / "x.out")], []

    def o_and_plot_same(d):
        rec = f.copy(d, "rec")
        return ["navigate", rec, "-o", d / "x.out", "--plot", d / "x.out", "-q"], [rec], [str(d / "x.out")], []

    def force_o_is_levers(d):
        rec, lev = f.copy(d, "rec"), f.copy(d, "levers")
        return ["compensate", rec, "--levers", lev, "-o", lev, "--force"], [rec, lev], [str(lev)], []

    def force_o_is_model(d):
        rec, model = f.copy(d, "rec"), f.copy(d, "model")
        return ["compensate", rec, "--model", model, "-o", model, "--force"], [rec, model], [str(model)], []

    def force_json_is_levers_nav(d):
        rec, lev = f.copy(d, "rec"), f.copy(d, "levers")
        return (["navigate", rec, "--levers", lev, "--json", lev, "--force", "-q"], [rec, lev], [str(lev)], [])

    def model_out_is_input(d):
        rec, model = f.copy(d, "tumble"), f.copy(d, "model")
        return (
            ["diagnose", rec, "--model", model, "--model-out", model, "--force", "--no-navigation"],
            [rec, model],
            [str(model)],
            [],
        )

    def symlink_to_input(d):
        rec = f.copy(d, "rec")
        link = d / "link.h5"
        link.symlink_to(rec)
        return ["navigate", rec, "-o", link, "--force", "-q"], [rec], [str(link), str(rec)], []

    def symlink_to_levers(d):
        rec, lev = f.copy(d, "rec"), f.copy(d, "levers")
        link = d / "link.h5"
        link.symlink_to(lev)
        return (["compensate", rec, "--levers", lev, "-o", link, "--force"], [rec, lev], [str(link), str(lev)], [])

    def hardlink_to_input(d):
        rec = f.copy(d, "rec")
        link = d / "hard.h5"
        os.link(rec, link)
        return ["navigate", rec, "-o", link, "--force", "-q"], [rec], [str(link), str(rec)], []

    def plots_existing(d):
        rec = f.copy(d, "tumble")
        plots = d / "plots"
        plots.mkdir()
        old = plots / "residuals.png"
        old.write_bytes(b"an older figure the user wants to keep")
        return (
            ["diagnose", rec, "--plots", plots, "--json", d / "d.json", "--no-navigation"],
            [rec, old],
            [str(plots), str(old)],
            [],
        )

    def plots_is_file(d):
        rec = f.copy(d, "tumble")
        plots = d / "plots"
        plots.write_text("a file, not a folder")
        return (["diagnose", rec, "--plots", plots, "--no-navigation"], [rec, plots], [str(plots)], [])

    def output_exists(d):
        old = d / "s.h5"
        old.write_bytes(b"precious")
        return (["simulate", "tumble", "-o", old, "-q", "--rate-hz", "100", "--duration-s", "2"], [old], [str(old)], [])

    def output_is_dir(d):
        (d / "s.h5").mkdir()
        return (
            ["simulate", "tumble", "-o", d / "s.h5", "-q", "--rate-hz", "100", "--duration-s", "2", "--force"],
            [],
            [str(d / "s.h5")],
            [],
        )

    def no_such_dir(d):
        rec = f.copy(d, "rec")
        return ["navigate", rec, "-o", d / "missing" / "nav.h5", "-q"], [rec], [str(d / "missing")], []

    def unwritable_dir(d):
        rec = f.copy(d, "rec")
        ro = d / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        return ["navigate", rec, "-o", ro / "nav.h5", "-q"], [rec], [str(ro)], [ro]

    def proc_dir(d):
        # unwritable even for root: procfs refuses new files whatever os.access says
        rec = f.copy(d, "rec")
        return ["navigate", rec, "-o", "/proc/self/nav.h5", "-q"], [rec], ["/proc/self"], []

    def calibrate_json_is_record(d):
        rec = f.copy(d, "rec")
        return ["calibrate", rec, "--json", rec, "--force"], [rec], [str(rec)], []

    def compare_json_is_b(d):
        a, b = f.copy(d, "rec", "a.h5"), f.copy(d, "rec", "b.h5")
        return ["compare", a, b, "--json", b, "--force"], [a, b], [str(b)], []

    def import_o_is_source(d):
        src = f.copy(d, "csv")
        return ["import", "csv", src, "-o", src, "--force", *CSV_OPTIONS], [src], [str(src)], []

    case("output-is-the-input-compensate", o_is_input)
    case("output-is-the-input-navigate", o_is_input_navigate)
    case("output-and-json-same-path", o_and_json_same)
    case("output-and-plot-same-path", o_and_plot_same)
    case("force-output-is-levers", force_o_is_levers)
    case("force-output-is-model", force_o_is_model)
    case("force-json-is-levers-navigate", force_json_is_levers_nav)
    case("force-model-out-is-model-diagnose", model_out_is_input)
    case("symlink-output-to-input", symlink_to_input)
    case("symlink-output-to-levers", symlink_to_levers)
    case("hardlink-output-to-input", hardlink_to_input)
    case("plots-with-existing-residuals-png", plots_existing)
    case("plots-is-a-file", plots_is_file)
    case("output-exists-without-force", output_exists)
    case("output-is-a-directory", output_is_dir)
    case("output-in-missing-directory", no_such_dir)
    case(
        "output-in-unwritable-directory",
        unwritable_dir,
        skip="running as root: permission bits do not bind root (the /proc case covers it)"
        if os.geteuid() == 0
        else None,
    )
    case("output-in-proc", proc_dir)
    case("calibrate-json-is-the-record", calibrate_json_is_record)
    case("compare-json-is-b", compare_json_is_b)
    case("import-output-is-the-source", import_o_is_source)
    return [dataclasses_replace_strs(c) for c in out]


def dataclasses_replace_strs(c: Case) -> Case:
    """Paths in argv become strings (the builders above mix Path and str for brevity)."""
    from dataclasses import replace

    return replace(c, argv=tuple(str(a) for a in c.argv))


def _fill(path, folder, f):
    """A base command line from :data:`BASES` with fresh inputs in ``folder``."""
    template = BASES[path]
    kept = []
    subs = {
        "out": str(folder / "out.json" if path == ("diagnose",) else folder / "out.h5"),
        "out2": str(folder / "model.toml"),
    }
    for key in ("rec", "tumble", "csv", "levers"):
        if "{" + key + "}" in template:
            p = f.copy(folder, key)
            kept.append(p)
            subs[key] = str(p)
    return tuple(path) + tuple(template.format(**subs).split()), kept


def numeric_option_cases(f) -> list:
    """Each numeric option of each command in :data:`BASES` with NaN, +-inf and 1e308, and -1,
    0 and 1e-300 where it must be positive, -1e308 where it need not (integers: NaN, -1, 0,
    10**30), appended to a small valid command line (click keeps the last)."""
    out = []
    for path, flag, kind in numeric_options():
        values = FLOAT_VALUES if kind == "float" else INT_VALUES
        if flag not in POSITIVE:  # -1, 0 and 1e-300 are ordinary values of a latitude or a heading
            values = tuple(v for v in values if v not in SIGN_VALUES) + ("-1e308",)
        for value in values:
            label = {
                "nan": "nan",
                "inf": "inf",
                "-inf": "minus-inf",
                "1e308": "1e308",
                "-1": "minus-1",
                "0": "zero",
                "1e-300": "1e-300",
                "-1e308": "minus-1e308",
            }.get(value, "1e30")
            name = f"option-{'-'.join(path)}{flag}-{label}"
            d = f.new(name)
            argv, kept = _fill(path, d, f)
            out.append(Case(name, argv + (flag, value), d, tuple(kept), option_expectation(flag, value), (flag,)))
    return out


# --------------------------------------------------------------------------- resource cases


def write_gzip_bomb(path, rows: int = BOMB_ROWS):
    """A telemetry file whose /imu datasets are gzip-compressed zeros: ``rows`` x 3 float64 each
    (4.8 GB at the default) in a few MB. Every chunk is the same pre-compressed block written
    with ``write_direct_chunk``, so this takes well under a second at 2e8 rows."""
    chunk = BOMB_CHUNK_ROWS
    n_chunks = -(-rows // chunk)
    block3 = zlib.compress(bytes(chunk * 3 * 8), 9)
    block1 = zlib.compress(bytes(chunk * 8), 9)
    with h5py.File(path, "w") as h5:
        write_root_attributes(h5)
        imu = h5.create_group("imu")
        t = imu.create_dataset("time", shape=(rows,), dtype="f8", chunks=(chunk,), compression="gzip")
        t.attrs["units"] = "s"
        for k in range(n_chunks):
            t.id.write_direct_chunk((k * chunk,), block1)
        for name, units in (("gyro", "rad/s"), ("accel", "m/s^2")):
            ds = imu.create_dataset(name, shape=(rows, 3), dtype="f8", chunks=(chunk, 3), compression="gzip")
            ds.attrs["units"] = units
            for k in range(n_chunks):
                ds.id.write_direct_chunk((k * chunk, 0), block3)
    return path


def write_huge_declared(path, rows: int = HUGE_DECLARED_ROWS):
    """A telemetry file declaring ``rows`` samples (240 GB at 10**10) of which none is written:
    chunked, resizable, only the fill value behind it."""
    with h5py.File(path, "w") as h5:
        write_root_attributes(h5)
        imu = h5.create_group("imu")
        imu.create_dataset("time", shape=(rows,), maxshape=(None,), chunks=(1 << 16,), dtype="f8").attrs["units"] = "s"
        for name, units in (("gyro", "rad/s"), ("accel", "m/s^2")):
            ds = imu.create_dataset(name, shape=(rows, 3), maxshape=(None, 3), chunks=(1 << 16, 3), dtype="f8")
            ds.attrs["units"] = units
    return path


def write_huge_declared_valid_start(path, rows: int = HUGE_DECLARED_ROWS):
    """As :func:`write_huge_declared`, but the first 1000 rows are a valid record: a reader that
    checks rows as it streams accepts them, then must stop at the declared size, not read 240 GB."""
    write_huge_declared(path, rows)
    src = np.arange(1000) / RATE_HZ
    with h5py.File(path, "r+") as h5:
        h5["imu/time"][:1000] = src
        h5["imu/gyro"][:1000] = np.tile([3.9e-5, 0.0, -6.2e-5], (1000, 1))
        h5["imu/accel"][:1000] = np.tile([0.0, 0.0, -9.817], (1000, 1))
    return path


#: Long-running or huge command lines: each must be refused, or finish, within the time limit.
HANG_CANDIDATES = {
    "hang-flight-altitude-minus-1e7": (
        "simulate",
        "flight",
        "--altitude-m",
        "-1e7",
        "--rate-hz",
        "50",
        "--reference-rate-hz",
        "10",
        "--duration-h",
        "0.3",
        "--align-s",
        "10",
    ),
    "hang-flight-duration-1e6-h": ("simulate", "flight", "--duration-h", "1e6"),
    "hang-tumble-duration-1e12-s": ("simulate", "tumble", "--duration-s", "1e12"),
    "hang-tumble-rate-1e9-hz": ("simulate", "tumble", "--duration-s", "1", "--rate-hz", "1e9"),
    "hang-turntable-cycles-1e9": ("simulate", "turntable", "--cycles", "1000000000"),
    "hang-sway-frequency-1e-12": ("simulate", "sway", "--frequency-hz", "1e-12", "--static-s", "1", "--segment-s", "2"),
    # 50000 segments of the default 600 s: 1 TB of samples behind one 100 kB argument (an
    # argument may not exceed 128 KiB on Linux)
    "hang-sway-amplitudes-50000-segments": ("simulate", "sway", "--amplitudes-dps", ",".join(["1"] * 50_000)),
}


def resource_cases(f, *, bomb_rows: int = BOMB_ROWS) -> list:
    """Memory bombs and hang candidates: subprocess cases, peak RSS measured."""
    out = []
    for kind, writer in (
        ("gzip-bomb", lambda p: write_gzip_bomb(p, bomb_rows)),
        ("huge-declared-shape", write_huge_declared),
        ("huge-declared-valid-start", write_huge_declared_valid_start),
    ):
        for command in ("inspect", "navigate", "compensate"):
            name = f"{kind}-{command}"
            d = f.new(name)
            rec = writer(d / "rec.h5")
            argv, extra = _reader_argv(f, command, rec, d)
            out.append(Case(name, argv, d, (rec,) + extra, REFUSE, (str(rec),), resource=True))
    for name, args in HANG_CANDIDATES.items():
        d = f.new(name)
        argv = args[:2] + ("-o", str(d / "s.h5"), "-q") + args[2:]
        # a refusal names an option, or the output when the record could not fit (a legal reason)
        names = tuple(a for a in args if a.startswith("--")) + (str(d / "s.h5"),)
        out.append(Case(name, argv, d, (), REFUSE, names, resource=True))
    d = f.new("fifo-input-inspect")
    fifo = d / "rec.h5"
    os.mkfifo(fifo)
    out.append(Case("fifo-input-inspect", ("inspect", str(fifo)), d, (), REFUSE, (str(fifo),), resource=True))
    out.append(
        Case(
            "dev-zero-input-inspect",
            ("inspect", "/dev/zero"),
            f.new("dev-zero-input-inspect"),
            (),
            REFUSE,
            ("/dev/zero",),
            resource=True,
        )
    )
    # a pipe or a device where a TOML model belongs: opening a FIFO blocks until a writer comes
    d = f.new("fifo-model-simulate")
    fifo = d / "model.toml"
    os.mkfifo(fifo)
    out.append(
        Case(
            "fifo-model-simulate",
            ("simulate", "tumble", "-o", str(d / "t.h5"), "--effects", str(fifo)),
            d,
            (),
            REFUSE,
            (str(fifo),),
            resource=True,
        )
    )
    d = f.new("dev-zero-model-simulate")
    out.append(
        Case(
            "dev-zero-model-simulate",
            ("simulate", "tumble", "-o", str(d / "t.h5"), "--effects", "/dev/zero"),
            d,
            (),
            REFUSE,
            ("/dev/zero",),
            resource=True,
        )
    )
    return out


# --------------------------------------------------------------------------- running and judging

#: Peak resident memory any case may reach. A refusal needs the interpreter with numpy, numba,
#: scipy and h5py loaded (about 0.25 GiB) plus bounded chunks (navigate's default chunk is 2**20
#: rows, ~0.2 GiB of working arrays); 1.5 GiB leaves room for that and for a forked test process,
#: and is far below what reading a bomb takes (one 2e8 x 3 float64 dataset is 4.5 GiB; the
#: declared 10**10-row dataset 224 GiB).
MEMORY_CEILING_BYTES = int(1.5 * 2**30)
#: Address-space limit put on every child so that a bomb that escapes the checks fails in the
#: child (MemoryError, reported) instead of taking the machine (23 GiB, no swap, 2 workers).
SAFETY_ADDRESS_SPACE_BYTES = 8 * 2**30
#: Seconds an in-process case may take: the slowest legal run here (diagnose of a 20 s record)
#: takes ~3 s on two cores; 15 s is a hang, not a slow machine.
IN_PROCESS_LIMIT_S = 15.0
#: Seconds a subprocess case may take: start-up is ~0.6 s and a refusal must come before any
#: bulk work, so 20 s means the command went on reading or computing.
SUBPROCESS_LIMIT_S = 20.0


@dataclass
class Outcome:
    """What one run did: exit code (None: killed at the time limit; negative: killed by that
    signal), its output, an in-process traceback, peak RSS, wall time, and the folder state."""

    case: Case
    exit_code: int | None
    stdout: str
    stderr: str
    traceback: str | None
    peak_rss_bytes: int
    seconds: float
    before: dict
    after: dict


def console_script() -> str | None:
    """The installed ``sizefx`` next to this interpreter (what a user runs), else on PATH."""
    exe = Path(sys.executable).parent / "sizefx"
    return str(exe) if exe.exists() else shutil.which("sizefx")


_CONSOLE_SCRIPT = console_script()


def snapshot(case: Case) -> dict:
    """Listing of the case folder (and watched folders) and SHA-256 of every kept file."""
    listing = {}
    for top in (case.folder, *case.watch):
        top = Path(top)
        entries = []
        if top.is_dir() and os.access(top, os.R_OK | os.X_OK):
            for dirpath, dirnames, filenames in os.walk(top):
                rel = os.path.relpath(dirpath, top)
                entries += [os.path.join(rel, n) + "/" for n in dirnames]
                entries += [os.path.join(rel, n) for n in filenames]
        listing[str(top)] = sorted(entries)
    sha = {}
    for p in case.kept:
        p = Path(p)
        sha[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None
    return {"listing": listing, "sha": sha}


def _limit_child():
    _resource.setrlimit(_resource.RLIMIT_AS, (SAFETY_ADDRESS_SPACE_BYTES, SAFETY_ADDRESS_SPACE_BYTES))


def _fresh_warnings():
    """Warnings as a fresh interpreter shows them, on (CliRunner's) stderr: pytest records them
    instead, which would hide a RuntimeWarning line that a user of the console script sees."""
    import warnings

    def show(msg):
        sys.stderr.write(warnings._formatwarnmsg(msg))

    warnings.showwarning = warnings._showwarning_orig
    warnings._showwarnmsg_impl = show  # pytest's catch_warnings(record=True) put a list.append here
    warnings.resetwarnings()
    for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
        warnings.simplefilter("ignore", category)


def _fork_invoke(argv, cwd, result_file):
    """Fork; the child runs ``main`` with click's CliRunner (no interpreter start-up, stderr
    apart from stdout) and pickles what happened into ``result_file``."""
    pid = os.fork()
    if pid:
        return pid
    code = 0
    try:
        _limit_child()
        os.chdir(cwd)
        _fresh_warnings()
        from click.testing import CliRunner

        from sizefx_cli.main import main

        res = CliRunner().invoke(main, list(argv), catch_exceptions=True, prog_name="sizefx")
        tb = None
        if res.exception is not None and not isinstance(res.exception, SystemExit):
            tb = "".join(_traceback.format_exception(*res.exc_info))
        payload = {"exit_code": res.exit_code, "stdout": res.stdout, "stderr": res.stderr, "traceback": tb}
    except BaseException:
        payload = {"exit_code": 1, "stdout": "", "stderr": "", "traceback": _traceback.format_exc()}
    try:
        with open(result_file, "wb") as fh:
            pickle.dump(payload, fh)
    except BaseException:
        code = 3
    os._exit(code)


def _spawn(argv, cwd, out_file, err_file, preexec=None):
    """Start the console script; stdout and stderr go to files (no pipe can fill up)."""
    import subprocess

    def pre():
        _limit_child()
        if preexec is not None:
            preexec()

    with open(out_file, "wb") as out, open(err_file, "wb") as err:
        proc = subprocess.Popen(
            [_CONSOLE_SCRIPT or "sizefx", *argv],
            cwd=cwd,
            stdout=out,
            stderr=err,
            stdin=subprocess.DEVNULL,
            preexec_fn=pre,
        )
    return proc


def run_cases(
    cases,
    scratch,
    *,
    workers: int | None = None,
    in_process_limit_s=IN_PROCESS_LIMIT_S,
    subprocess_limit_s=SUBPROCESS_LIMIT_S,
    subprocess_all: bool = False,
    progress=None,
) -> dict:
    """Run ``cases`` (``workers`` at a time, one thread: children are forked or spawned and
    reaped with ``os.wait4``, which gives each child's own peak RSS) and return
    ``{name: Outcome}``. Resource cases, and every case with ``subprocess_all``, run the
    console script; the others a forked CliRunner."""
    scratch = Path(scratch)
    scratch.mkdir(parents=True, exist_ok=True)
    workers = workers or os.cpu_count() or 2
    pending = [c for c in cases if c.skip is None]
    running = {}
    results = {}
    while pending or running:
        while pending and len(running) < workers:
            case = pending.pop(0)
            before = snapshot(case)
            tag = scratch / re.sub(r"[^A-Za-z0-9_.-]", "_", case.name)
            sub = case.resource or subprocess_all
            if sub:
                try:
                    proc = _spawn(case.argv, case.folder, f"{tag}.out", f"{tag}.err")
                except OSError as exc:  # the command line cannot be started (too long, no script)
                    results[case.name] = Outcome(case, -1, "", "", f"could not start: {exc}", 0, 0.0, before, before)
                    continue
                pid, limit = proc.pid, subprocess_limit_s
            else:
                pid, proc, limit = _fork_invoke(case.argv, case.folder, f"{tag}.pickle"), None, in_process_limit_s
            running[pid] = (case, before, tag, proc, time.monotonic(), limit)
        time.sleep(0.002)
        for pid in list(running):
            case, before, tag, proc, t0, limit = running[pid]
            done, status, usage = os.wait4(pid, os.WNOHANG)
            timed_out = False
            if not done:
                if time.monotonic() - t0 < limit:
                    continue
                os.kill(pid, signal.SIGKILL)
                done, status, usage = os.wait4(pid, 0)
                timed_out = True
            seconds = time.monotonic() - t0
            if proc is not None:
                proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
                stdout = Path(f"{tag}.out").read_text(errors="replace")
                stderr = Path(f"{tag}.err").read_text(errors="replace")
                code, tb = proc.returncode, None
            else:
                try:
                    with open(f"{tag}.pickle", "rb") as fh:
                        payload = pickle.load(fh)
                    code, stdout, stderr, tb = (
                        payload["exit_code"],
                        payload["stdout"],
                        payload["stderr"],
                        payload["traceback"],
                    )
                except (OSError, EOFError, pickle.UnpicklingError):
                    code, stdout, stderr = os.waitstatus_to_exitcode(status), "", ""
                    tb = None if timed_out else f"the forked child died with status {code} before reporting"
            del running[pid]
            results[case.name] = Outcome(
                case,
                None if timed_out else code,
                stdout,
                stderr,
                tb,
                usage.ru_maxrss * 1024,
                seconds,
                before,
                snapshot(case),
            )
            if progress is not None:
                progress(results[case.name])
    return results


_TEMP_NAME = re.compile(r"\.tmp\b|\btmp[a-z0-9_]{8}\b")


def broken_promises(o: Outcome, *, limit_s=None) -> list:
    """Every promise the run broke, one sentence each (empty: all kept)."""
    c = o.case
    broken = []
    if o.exit_code is None:
        broken.append(f"time: no exit within {limit_s or o.seconds:.0f} s (a hang or unbounded work); killed")
    elif o.exit_code not in c.expect:
        how = f"killed by signal {-o.exit_code}" if o.exit_code < 0 else f"exit code {o.exit_code}"
        broken.append(f"exit code: expected {' or '.join(map(str, c.expect))}, got {how}")
    tb_text = (
        (o.traceback or "")
        + ("\n" + o.stderr if "Traceback" in o.stderr else "")
        + ("\n" + o.stdout if "Traceback" in o.stdout else "")
    )
    if tb_text.strip():
        broken.append(f"traceback: {tail(tb_text)}")
    if o.exit_code == 2:
        lines = o.stderr.splitlines()
        if len(lines) != 1:
            broken.append(f"one line: stderr has {len(lines)} lines: {o.stderr.strip()[:300]!r}")
        first = lines[0] if lines else ""
        if not first.startswith("sizefx: error:"):
            broken.append(f"one line: stderr does not start with 'sizefx: error:': {first[:200]!r}")
        if c.names and not any(n in o.stderr for n in _spellings(c.names)):
            broken.append(f"names the file: the message names none of {list(c.names)}: {first[:200]!r}")
        if _TEMP_NAME.search(o.stderr):
            broken.append(f"names the file: the message names a temporary file: {first[:200]!r}")
    for path, digest in o.before["sha"].items():
        now = o.after["sha"].get(path)
        if now != digest:
            broken.append(f"input unchanged: {path} was {'deleted' if now is None else 'modified'}")
    if o.exit_code != 0:
        for top, entries in o.before["listing"].items():
            after = o.after["listing"].get(top, [])
            if after != entries:
                new = sorted(set(after) - set(entries))
                gone = sorted(set(entries) - set(after))
                broken.append(f"no output left: {top} changed (new {new[:5]}, gone {gone[:5]})")
    leftovers = [e for entries in o.after["listing"].values() for e in entries if _TEMP_NAME.search(e)]
    if leftovers:
        broken.append(f"no output left: temporary files remain: {leftovers[:5]}")
    if o.peak_rss_bytes > MEMORY_CEILING_BYTES:
        broken.append(
            f"memory: peak RSS {o.peak_rss_bytes / 2**30:.2f} GiB over the "
            f"{MEMORY_CEILING_BYTES / 2**30:.1f} GiB ceiling"
        )
    return broken


def _spellings(names):
    """A file by its path; an option by its flag or its bare name (``--rate-hz``, ``rate-hz``,
    ``rate_hz``); a ``--set`` key by its last part (``[accel_delay] tau_s`` names it)."""
    out = set()
    for n in names:
        out.add(n)
        if n.startswith("--") and len(n) > 2:
            out |= {n[2:], n[2:].replace("-", "_")}
        elif "." in n and "/" not in n:
            out.add(n.rsplit(".", 1)[1])
    return out


def tail(text: str) -> str:
    """The last meaningful line of a traceback or output (what a developer greps for)."""
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1].strip()[:300] if lines else ""


def describe(o: Outcome, broken) -> str:
    """A failure message a developer can act on: the case, the command, what broke."""
    cmd = "sizefx " + " ".join(a if len(a) < 80 else a[:60] + "..." for a in o.case.argv)
    first = o.stderr.strip().splitlines()[0][:300] if o.stderr.strip() else ""
    return (
        f"case {o.case.name}: {cmd}\n  exit {o.exit_code}, {o.seconds:.1f} s, peak RSS "
        f"{o.peak_rss_bytes / 2**20:.0f} MiB; stderr: {first!r}\n  broken: " + "\n  broken: ".join(broken)
    )
