"""The sizefx/telemetry/1 contract: round trips, and one test per kind of bad input."""

from __future__ import annotations

import hashlib
import os
import threading

import h5py
import numpy as np
import pytest
from support import RATE_HZ, N, write_raw

from sizefx.errors import OutputError, TelemetryError
from sizefx.io.files import HASH_CHUNK_BYTES, sha256_of
from sizefx.io.schema import load_schema
from sizefx.io.telemetry import Provenance, Reference, Site, Telemetry, read_telemetry, write_telemetry

DEG = np.pi / 180


# --------------------------------------------------------------------------- round trips


def _telemetry(form, *, accel_time=False, ref_position=True, ref_velocity=True, simulation=None):
    rng = np.random.default_rng(7)
    n, m = 500, 50
    t = np.arange(n) / 200.0
    a, b = rng.standard_normal((n, 3)), rng.standard_normal((n, 3)) + [0, 0, -9.8]
    q = rng.standard_normal((m, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    ref = Reference(time_s=np.arange(m) / 20.0, quat_nb=q)
    if ref_position:
        ref.lat_rad, ref.lon_rad, ref.height_m = rng.uniform(-1, 1, m), rng.uniform(-3, 3, m), rng.uniform(0, 900, m)
    if ref_velocity:
        ref.velocity_n_mps = rng.standard_normal((m, 3))
    tel = Telemetry(
        time_s=t,
        form=form,
        reference=ref,
        site=Site(0.5, 1.0, 10.0),
        description="round trip",
        simulation=simulation,
        accel_time_s=t + 1e-4 if accel_time else None,
    )
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = a * 0.1, b
    else:
        tel.dtheta_rad, tel.dvel_mps = a * 0.1 / 200.0, b / 200.0
    return tel


@pytest.mark.parametrize("form", ["rates", "increments"])
@pytest.mark.parametrize("accel_time", [False, True])
@pytest.mark.parametrize("ref_position,ref_velocity", [(True, True), (False, False), (True, False)])
def test_round_trip_every_dataset_kind(tmp_path, form, accel_time, ref_position, ref_velocity):
    tel = _telemetry(
        form,
        accel_time=accel_time,
        ref_position=ref_position,
        ref_velocity=ref_velocity,
        simulation={"scenario": "custom", "seed": 3, "effects": {"x": [1, 2]}},
    )
    path = write_telemetry(tmp_path / "rt.h5", tel)
    back = read_telemetry(path, check_plausibility=False)
    assert back.form == form
    for name in ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s"):
        want, got = getattr(tel, name), getattr(back, name)
        assert (want is None) == (got is None), name
        if want is not None:
            np.testing.assert_array_equal(got, want, err_msg=name)  # float64 storage is lossless
    # the reader renormalises quaternions: equal to a few ulp
    np.testing.assert_allclose(back.reference.quat_nb, tel.reference.quat_nb, rtol=0, atol=4e-16)
    assert back.reference.has_position == ref_position
    if ref_position:
        # stored in degrees: one multiplication and one division by pi/180 apart
        np.testing.assert_allclose(back.reference.lat_rad, tel.reference.lat_rad, rtol=1e-15, atol=1e-16)
        np.testing.assert_array_equal(back.reference.height_m, tel.reference.height_m)
    assert (back.reference.velocity_n_mps is not None) == ref_velocity
    assert back.simulation == {"scenario": "custom", "seed": 3, "effects": {"x": [1, 2]}}
    assert back.site.height_m == 10.0 and back.description == "round trip"


def test_round_trip_float32_storage(tmp_path):
    tel = _telemetry("rates")
    back = read_telemetry(write_telemetry(tmp_path / "f32.h5", tel, dtype=np.float32), check_plausibility=False)
    assert back.stored_dtypes["/imu/gyro"] == "float32"
    assert back.stored_dtypes["/imu/time"] == "float64"  # time keeps full precision whatever the data dtype
    # float32 keeps 24 bits: relative error below 2^-24
    np.testing.assert_allclose(back.accel_mps2, tel.accel_mps2, rtol=2**-24)


def test_reader_converts_non_si_units(tmp_path):
    def to_degrees_and_g(h5):
        g = h5["imu/gyro"][()]
        f = h5["imu/accel"][()]
        del h5["imu/gyro"], h5["imu/accel"]
        h5["imu"].create_dataset("gyro", data=np.degrees(g)).attrs["units"] = "deg/s"
        h5["imu"].create_dataset("accel", data=f / 9.80665).attrs["units"] = "g"

    si = read_telemetry(write_raw(tmp_path / "si.h5"))
    other = read_telemetry(write_raw(tmp_path / "deg.h5", mutate=to_degrees_and_g))
    np.testing.assert_allclose(other.gyro_rad_s, si.gyro_rad_s, rtol=1e-14)
    np.testing.assert_allclose(other.accel_mps2, si.accel_mps2, rtol=1e-14)
    assert other.stored_units["/imu/gyro"] == "deg/s"


def test_writer_is_atomic_and_refuses_to_overwrite(tmp_path):
    out = tmp_path / "out.h5"
    tel = _telemetry("rates")
    write_telemetry(out, tel)
    with pytest.raises(OutputError, match="--force"):
        write_telemetry(out, tel)
    before = out.read_bytes()
    # a failure during the write leaves the old file untouched and no temporary behind
    bad = _telemetry("rates")
    bad.accel_mps2 = bad.accel_mps2[:10]
    with pytest.raises(RuntimeError, match=r"incomplete write .*/imu/accel.*\(10, 500\)"):
        write_telemetry(out, bad, force=True)  # 10 accel rows written where 500 were declared
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5"]
    with pytest.raises(OutputError, match="overwrite the input"):
        write_telemetry(out, tel, inputs=[out], force=True)


def test_schema_is_what_the_reader_enforces():
    schema = load_schema("sizefx/telemetry/1")
    assert set(schema["forms"]) == {"rates", "increments"}
    assert schema["units"]["acceleration"]["g"] == 9.80665
    assert schema["units"]["angular_rate"]["deg/s"] == pytest.approx(DEG, rel=1e-15)


# --------------------------------------------------------------------------- bad input


def _replace(name, data, units=None):
    def mutate(h5):
        old_units = h5[name].attrs.get("units")
        del h5[name]
        d = h5.create_dataset(name, data=data)
        if units is not None or old_units is not None:
            d.attrs["units"] = units if units is not None else old_units

    return mutate


def _set_row(name, row, value):
    def mutate(h5):
        d = h5[name][()]
        d[row] = value
        h5[name][...] = d

    return mutate


def _scale(name, factor):
    def mutate(h5):
        h5[name][...] = h5[name][()] * factor

    return mutate


def _time_with(change):
    def mutate(h5):
        t = h5["imu/time"][()]
        change(t)
        h5["imu/time"][...] = t

    return mutate


def _external_link(tmp_path):
    def mutate(h5):
        other = tmp_path / "other.h5"
        with h5py.File(other, "w") as o:
            o["accel"] = np.zeros((N, 3))
        del h5["imu/accel"]
        h5["imu/accel"] = h5py.ExternalLink(str(other), "/accel")

    return mutate


def _virtual(tmp_path):
    def mutate(h5):
        other = tmp_path / "src.h5"
        with h5py.File(other, "w") as o:
            o["accel"] = np.tile([0.0, 0.0, -9.8], (N, 1))
        layout = h5py.VirtualLayout(shape=(N, 3), dtype="f8")
        layout[:] = h5py.VirtualSource(str(other), "accel", shape=(N, 3))
        del h5["imu/accel"]
        h5["imu"].create_virtual_dataset("accel", layout).attrs["units"] = "m/s^2"

    return mutate


def _drop(name):
    def mutate(h5):
        del h5[name]

    return mutate


def _attr(name, key, value):
    def mutate(h5):
        if value is None:
            del h5[name].attrs[key]
        else:
            h5[name].attrs[key] = value

    return mutate


def _reference_position(lat_deg):
    """A /reference/position whose every row has latitude ``lat_deg`` [deg]."""

    def mutate(h5):
        rows = h5["reference/time"].shape[0]
        pos = np.tile([lat_deg, 13.3, 40.0], (rows, 1))
        h5.create_dataset("reference/position", data=pos).attrs["units"] = "deg,deg,m"

    return mutate


#: Text that is not UTF-8 (Latin-1 "café", then bytes no encoding starts with), and how sizefx carries it.
NOT_UTF8 = b"caf\xe9 \xff\xfe"
NOT_UTF8_ESCAPED = "caf\\xe9 \\xff\\xfe"


def _text_not_utf8(name, key):
    """Attribute ``key`` of ``name`` (a group made if missing) holding :data:`NOT_UTF8` declared as UTF-8."""

    def mutate(h5):
        target = h5[name] if name in h5 else h5.create_group(name)
        target.attrs.create(key, data=NOT_UTF8, dtype=h5py.string_dtype("utf-8"))

    return mutate


BAD_CASES = {
    # id: (mutate factory taking tmp_path, expected dataset, expected words)
    "missing schema attribute": (lambda p: _attr("/", "schema", None), "/", "schema"),
    "wrong schema": (lambda p: _attr("/", "schema", "other/1"), "/", "expected 'sizefx/telemetry/1'"),
    "missing imu group": (lambda p: _drop("imu"), "/imu", "missing"),
    "missing dataset": (lambda p: _drop("imu/accel"), "/imu/accel", "missing"),
    "no imu data": (lambda p: lambda h5: (_drop("imu/accel")(h5), _drop("imu/gyro")(h5)), "/imu", "neither"),
    "both forms": (
        lambda p: (
            lambda h5: (
                h5["imu"].create_dataset("dtheta", data=np.zeros((N, 3))),
                h5["imu"].create_dataset("dvel", data=np.zeros((N, 3))),
            )
        ),
        "/imu",
        "both",
    ),
    "wrong rank": (lambda p: _replace("imu/gyro", np.zeros(N)), "/imu/gyro", "rank 1"),
    "wrong shape": (lambda p: _replace("imu/gyro", np.zeros((N, 4))), "/imu/gyro", "length 3"),
    "row count mismatch": (lambda p: _replace("imu/accel", np.zeros((N - 1, 3))), "/imu/accel", "rows"),
    "integer dtype": (lambda p: _replace("imu/gyro", np.zeros((N, 3), dtype=np.int32)), "/imu/gyro", "dtype int32"),
    "unknown units": (lambda p: _attr("imu/gyro", "units", "dps"), "/imu/gyro", "units 'dps' are not known"),
    "missing units": (lambda p: _attr("imu/accel", "units", None), "/imu/accel", "no 'units'"),
    "wrong time units": (lambda p: _attr("imu/time", "units", "ms"), "/imu/time", "units 'ms'"),
    "NaN": (lambda p: _set_row("imu/accel", 17, np.nan), "/imu/accel", "NaN/Inf values, the first at row 17"),
    "Inf": (lambda p: _set_row("imu/gyro", 3, np.inf), "/imu/gyro", "row 3"),
    "time goes back": (
        lambda p: _time_with(lambda t: t.__setitem__(500, t[498])),
        "/imu/time",
        "not strictly increasing",
    ),
    "duplicated timestamp": (lambda p: _time_with(lambda t: t.__setitem__(500, t[499])), "/imu/time", "duplicated"),
    "gap": (
        lambda p: _time_with(lambda t: t.__setitem__(slice(600, None), t[600:] + 0.5)),
        "/imu/time",
        "1 undeclared gap longer than 1.5",
    ),
    "time in milliseconds": (lambda p: _time_with(lambda t: t.__imul__(1000.0)), "/imu/time", "ms or us"),
    "accel in g labelled m/s^2": (
        lambda p: _scale("imu/accel", 1 / 9.80665),
        "/imu/accel",
        "the data look like g: set the units attribute to 'g'",
    ),
    "accel in m/s^2 labelled g": (
        lambda p: _attr("imu/accel", "units", "g"),
        "/imu/accel",
        "the data look like m/s^2: set the units attribute to 'm/s^2'",
    ),
    "gyro in deg/s labelled rad/s": (
        lambda p: _replace("imu/gyro", np.full((N, 3), 30.0)),
        "/imu/gyro",
        "the data look like deg/s: set the units attribute to 'deg/s'",
    ),
    "non-unit quaternion": (
        lambda p: _set_row("reference/quaternion", 4, [1.0, 0.1, 0.0, 0.0]),
        "/reference/quaternion",
        "row 4 has norm",
    ),
    "reference without time": (lambda p: _drop("reference/time"), "/reference/time", "missing"),
    "external link": (_external_link, "/imu/accel", "external link"),
    "virtual dataset": (_virtual, "/imu/accel", "virtual dataset"),
    "partial site": (lambda p: _attr("/", "height_m", None), "/", "not height_m"),
    "latitude out of range": (lambda p: _attr("/", "latitude_deg", 95.0), "/", "latitude_deg = 95.0"),
    # a site at a pole: the attribute, the valid range and why (the place, not the file, is the problem)
    "site at the north pole": (
        lambda p: _attr("/", "latitude_deg", 90.0),
        "/",
        "root attribute latitude_deg = 90.0 is outside [-89.5, 89.5] (within 0.5 deg of a pole",
    ),
    "reference at the south pole": (
        lambda p: _reference_position(-90.0),
        "/reference/position",
        "latitude (column 0) is -90 deg at row 0",
    ),
    "reference latitude beyond the poles": (
        lambda p: _reference_position(100.0),
        "/reference/position",
        "outside [-89.5, 89.5] deg; beyond the poles: check the units attribute",
    ),
    # text sizefx interprets is refused when it is not UTF-8, with the bytes it cannot decode escaped
    "units not UTF-8": (
        lambda p: _text_not_utf8("imu/gyro", "units"),
        "/imu/gyro",
        "units 'caf\\xe9\\xff\\xfe' are not known",
    ),
    "object name not UTF-8": (
        lambda p: lambda h5: h5.create_group(b"extra" + NOT_UTF8),
        "/extra" + NOT_UTF8_ESCAPED,
        "an HDF5 object whose name is not UTF-8 text",
    ),
    "empty dataset": (
        lambda p: (
            lambda h5: [
                _replace("imu/" + k, np.zeros((0, 3)) if k != "time" else np.zeros(0))(h5)
                for k in ("time", "gyro", "accel")
            ]
        ),
        "/imu/time",
        "no samples",
    ),
}


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_each_bad_input_is_refused_with_file_dataset_and_problem(tmp_path, case):
    factory, dataset, words = BAD_CASES[case]
    path = write_raw(tmp_path / "bad.h5", mutate=factory(tmp_path))
    with pytest.raises(TelemetryError) as info:
        read_telemetry(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: {dataset}: "), msg
    assert words in msg, msg
    assert "\n" not in msg


def test_not_hdf5(tmp_path):
    path = tmp_path / "log.h5"
    path.write_text("time,gx,gy\n0,1,2\n")
    with pytest.raises(TelemetryError, match="not an HDF5 file"):
        read_telemetry(path)


def test_empty_file(tmp_path):
    path = tmp_path / "empty.h5"
    path.write_bytes(b"")
    with pytest.raises(TelemetryError, match="empty"):
        read_telemetry(path)


def test_truncated_file(tmp_path):
    full = write_raw(tmp_path / "full.h5")
    data = full.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(TelemetryError, match="truncated or corrupt"):
        read_telemetry(cut)


def test_missing_file(tmp_path):
    with pytest.raises(TelemetryError, match="does not exist"):
        read_telemetry(tmp_path / "nope.h5")


def test_gaps_can_be_allowed_and_are_reported(tmp_path):
    path = write_raw(tmp_path / "gap.h5", mutate=_time_with(lambda t: t.__setitem__(slice(600, None), t[600:] + 0.5)))
    tel = read_telemetry(path, allow_gaps=True)
    assert len(tel.gaps) == 1
    gap = tel.gaps[0]
    assert gap.index == 600 and gap.duration_s == pytest.approx(0.5 + 1 / RATE_HZ)


def test_valid_raw_file_reads(raw_file):
    tel = read_telemetry(raw_file)
    assert tel.n_samples == N and tel.sample_rate_hz == pytest.approx(RATE_HZ)
    assert tel.reference is not None and not tel.reference.has_position


def test_source_attributes_round_trip(tmp_path):
    tel = _telemetry("rates")
    tel.source = Provenance(
        format="csv",
        file="x.csv",
        extra={
            "axis_map": ["y", "x", "-z"],
            "gyro_bias_rad_s_frd": [1e-5, 0.0, 2.0],
            "dropouts": 3,
            "approximate": True,
        },
    )
    back = read_telemetry(write_telemetry(tmp_path / "s.h5", tel), check_plausibility=False)
    assert back.source == tel.source and back.source.extra["axis_map"] == ("y", "x", "-z")


def test_reference_gaps_are_reported_not_refused(tmp_path):
    def drop_reference_rows(h5):
        t = h5["reference/time"][()]
        q = h5["reference/quaternion"][()]
        keep = np.r_[0:40, 60 : t.size]
        del h5["reference/time"], h5["reference/quaternion"]
        h5["reference"].create_dataset("time", data=t[keep]).attrs["units"] = "s"
        h5["reference"].create_dataset("quaternion", data=q[keep])

    tel = read_telemetry(write_raw(tmp_path / "refgap.h5", mutate=drop_reference_rows))
    assert [(g.dataset, g.index) for g in tel.gaps] == [("/reference/time", 40)]


def test_outputs_get_ordinary_file_permissions(tmp_path):
    """mkstemp makes 0600 files; a finished output must be readable like any new file (umask applied)."""
    from sizefx.io.files import atomic_output

    out = tmp_path / "o.txt"
    with atomic_output(out) as tmp:
        tmp.write_text("x")
    mask = os.umask(0)
    os.umask(mask)
    assert (out.stat().st_mode & 0o777) == 0o666 & ~mask


@pytest.mark.parametrize("size", [0, 1, HASH_CHUNK_BYTES - 1, HASH_CHUNK_BYTES, 2 * HASH_CHUNK_BYTES + 5])
def test_sha256_of_a_mapped_file_is_hashlibs(tmp_path, size):
    """Mapped a window at a time: the digest of the bytes, at and around the window's size."""
    path = tmp_path / "f.bin"
    data = np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes()
    path.write_bytes(data)
    assert sha256_of(path) == hashlib.sha256(data).hexdigest()


@pytest.mark.parametrize("size", [0, HASH_CHUNK_BYTES + 5])
def test_sha256_of_read_is_the_mapped_one(tmp_path, size):
    """mapped=False (a command's own process) reads: the same digest."""
    path = tmp_path / "f.bin"
    path.write_bytes(np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes())
    assert sha256_of(path, mapped=False) == sha256_of(path) == hashlib.sha256(path.read_bytes()).hexdigest()


def test_sha256_of_a_file_that_cannot_be_mapped_is_read(tmp_path, monkeypatch):
    """A file system that refuses mmap (OSError) part way: the rest is read, the digest unchanged."""
    import mmap

    from sizefx.io import files

    path = tmp_path / "f.bin"
    path.write_bytes(bytes(range(256)) * (HASH_CHUNK_BYTES // 128 + 3))
    real, calls = mmap.mmap, []

    def refuse_second(*args, **kwargs):
        calls.append(kwargs.get("offset"))
        if len(calls) == 2:
            raise OSError(19, "No such device")
        return real(*args, **kwargs)

    monkeypatch.setattr(files.mmap, "mmap", refuse_second)
    assert sha256_of(path) == hashlib.sha256(path.read_bytes()).hexdigest()
    assert calls == [0, HASH_CHUNK_BYTES]


def test_sha256_of_a_pipe_reads_it(tmp_path):
    """What is not a regular file (a named pipe) is read to its end."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    data = b"sizefx" * 100_000
    writer = threading.Thread(target=lambda: fifo.write_bytes(data))
    writer.start()
    assert sha256_of(fifo) == hashlib.sha256(data).hexdigest()
    writer.join()


def test_text_attributes_that_are_not_utf8_are_carried_with_escapes(tmp_path):
    """A description or /source attribute (its value or its name) that is not UTF-8 is informational:
    read as valid text with the undecodable bytes as backslash escapes, and written back as such (h5py
    cannot write the lone surrogates it reads them as)."""

    def mutate(h5):
        _text_not_utf8("/", "description")(h5)
        _text_not_utf8("source", "comment")(h5)
        _text_not_utf8("source", b"note" + NOT_UTF8)(h5)

    tel = read_telemetry(write_raw(tmp_path / "latin1.h5", mutate=mutate))
    assert tel.description == NOT_UTF8_ESCAPED
    assert tel.source is not None
    assert tel.source.extra == {"comment": NOT_UTF8_ESCAPED, "note" + NOT_UTF8_ESCAPED: NOT_UTF8_ESCAPED}
    out = write_telemetry(tmp_path / "copy.h5", tel)
    with h5py.File(out) as h5:
        assert h5.attrs["description"] == NOT_UTF8_ESCAPED
        assert dict(h5["source"].attrs) == tel.source.extra
    assert read_telemetry(out).description.encode("utf-8")  # valid text all the way
