"""``/source`` as a typed record (:mod:`sizefx.io.provenance`): built in memory, written, read back.

The layout on disk is the one sizefx always wrote (``data-schemas/telemetry-1.json``, ``/source``):
a file written before the record was typed reads into its fields, and written back holds the same
attributes, in the same order, with the same JSON text.
"""

from __future__ import annotations

import dataclasses
import json

import h5py
import numpy as np
import pytest

from sizefx.io.provenance import Provenance, from_attributes, to_attributes
from sizefx.io.telemetry import Telemetry, read_telemetry, write_telemetry

#: What ``compensate --levers`` recorded, as ``json.dumps`` wrote it.
COMPENSATION = {"mode": "triad", "estimator": "savgol", "accel_delay_s": 0.0, "arms_m": [[0.02, 0.0, 0.0]] * 3}
CORRECTION = {"model": "m.toml", "corrected": ["lever_arm"], "effects": {"accel_delay": {"tau_s": 5e-4}}}


def _record(source: Provenance | None = None) -> Telemetry:
    rng = np.random.default_rng(3)
    n = 200
    return Telemetry(
        time_s=np.arange(n) / 100.0,
        form="rates",
        gyro_rad_s=rng.normal(0.0, 1e-3, (n, 3)),
        accel_mps2=np.tile([0.0, 0.0, -9.81], (n, 1)) + rng.normal(0.0, 1e-3, (n, 3)),
        source=source,
    )


def _source_attributes(path, *, stored: bool = False) -> list:
    """``/source``'s attributes as (name, plain value): in the order h5py lists them (by name, for a
    group that does not track the order), or with ``stored`` in the order the file stores them (the
    order they were written in, which its bytes show)."""
    with h5py.File(path) as h5:
        attrs = h5["source"].attrs
        names = list(attrs)
        if stored:
            names = []
            h5py.h5a.iterate(
                h5["source"].id,
                lambda name, *_: names.append(name.decode()),
                index_type=h5py.h5.INDEX_NAME,
                order=h5py.h5.ITER_NATIVE,
            )
        return [(k, attrs[k].tolist() if isinstance(attrs[k], np.ndarray) else attrs[k]) for k in names]


def test_the_typed_record_round_trips_through_a_file(tmp_path):
    imu = Provenance(format="csv", file="imu.csv", sha256="a" * 64, importer="sizefx 0", extra={"dropouts": 2})
    prov = Provenance(
        format="table-log",
        file="log.csv",
        sha256="b" * 64,
        importer="sizefx 0",
        credits="the authors, CC BY 4.0",
        extra={"axes": ["z", "-y"], "mount_deg": np.array([0.0, 1.5, 2.0]), "reference_is_approximate": True},
        imu=imu,
        correction=CORRECTION,
        compensation=COMPENSATION,
    )
    path = write_telemetry(tmp_path / "r.h5", _record(prov))
    back = read_telemetry(path, check_plausibility=False).source
    assert back == prov and back is not prov
    assert back.imu == imu and back.imu.extra["dropouts"] == 2
    assert back.extra["axes"] == ("z", "-y") and back.extra["mount_deg"] == (0.0, 1.5, 2.0)
    assert back.reference_is_approximate and not imu.reference_is_approximate
    assert (
        back.compensation["arms_m"][0] == (0.02, 0.0, 0.0)
        and back.correction["effects"]["accel_delay"]["tau_s"] == 5e-4
    )
    attrs = dict(_source_attributes(path))
    assert json.loads(attrs["compensation_json"]) == COMPENSATION and attrs["imu_source_file"] == "imu.csv"
    assert "credits" in attrs and "imu" not in attrs
    # written in the order the importers always wrote: the fixed fields, the importer's, the IMU's, what was done
    assert [k for k, _ in _source_attributes(path, stored=True)] == [
        "format",
        "file",
        "sha256",
        "importer",
        "credits",
        "axes",
        "mount_deg",
        "reference_is_approximate",
        "imu_source_format",
        "imu_source_file",
        "imu_source_sha256",
        "imu_source_importer",
        "imu_source_dropouts",
        "correction_json",
        "compensation_json",
    ]


def test_a_file_written_before_the_record_was_typed_reads_into_its_fields(tmp_path):
    """The attributes as the importers and compensate wrote them by hand: the same record, and written
    back the same attributes, values and JSON text, in the order the file lists them."""
    path = write_telemetry(tmp_path / "old.h5", _record())
    with h5py.File(path, "a") as h5:
        g = h5.create_group("source")
        g.attrs["format"] = "psins-imu"
        g.attrs["file"] = "log.bin"
        g.attrs["sha256"] = "c" * 64
        g.attrs["importer"] = "sizefx 0.0.9"
        g.attrs["body_axes"] = "RFU"
        g.attrs["reference_is_approximate"] = True
        g.attrs["gyro_lsb_arcsec"] = [0.1, 0.1, 0.2]
        g.attrs["imu_source_format"] = "ulog"
        g.attrs["imu_source_dropouts"] = 4
        g.attrs["compensation_json"] = json.dumps(COMPENSATION)
    tel = read_telemetry(path, check_plausibility=False)
    src = tel.source
    assert (src.format, src.file, src.sha256, src.importer, src.credits) == (
        "psins-imu",
        "log.bin",
        "c" * 64,
        "sizefx 0.0.9",
        None,
    )
    assert src.reference_is_approximate and src.extra["gyro_lsb_arcsec"] == (0.1, 0.1, 0.2)
    assert src.imu == Provenance(format="ulog", extra={"dropouts": 4})
    assert src.compensation["mode"] == "triad" and src.compensation["arms_m"] == ((0.02, 0.0, 0.0),) * 3
    assert "compensation_json" not in src.extra and src.correction is None
    copy = write_telemetry(tmp_path / "copy.h5", tel)
    assert _source_attributes(copy, stored=True) == _source_attributes(path)  # as read, so written
    assert _source_attributes(path, stored=True)[0][0] == "format"  # the file's own order: not the one read


def test_attributes_sizefx_did_not_write_are_carried_as_they_are():
    """A name with a value of another type, JSON not in the default form: left in ``extra``, and the
    attributes come back in the order they were read, new ones after."""
    read = {
        "zeta": "z",
        "format": 7,
        "compensation_json": '{"mode":"center"}',
        "correction_json": "[1, 2]",
        "credits": "",
        "imu_source_": "no name",
        "alpha": [[0.0, 1.0], [2.0, 3.0]],
    }
    prov = from_attributes(read)
    assert prov.format is None and prov.extra["format"] == 7 and prov.compensation is None and prov.correction is None
    assert prov.credits == "" and prov.imu == Provenance(extra={"": "no name"})
    assert list(to_attributes(prov).items()) == list(read.items())
    # compensate over it: its record replaces the text it could not read, where the file had it
    done = to_attributes(dataclasses.replace(prov, compensation={"mode": "triad"}))
    assert list(done) == list(read) and done["compensation_json"] == '{"mode": "triad"}'
    # a new record from an importer: the fixed fields first, then the importer's own, then what was done
    fresh = Provenance(format="csv", extra={"b": 1, "a": 2}, compensation={"mode": "center"}, file="x.csv")
    assert list(to_attributes(fresh)) == ["format", "file", "b", "a", "compensation_json"]


def test_a_record_is_read_only_all_the_way_down():
    prov = Provenance(format="csv", extra={"columns": ["a", "b"]}, compensation={"arms_m": [[1.0]]})
    with pytest.raises(dataclasses.FrozenInstanceError):
        prov.format = "ulog"  # type: ignore[misc]
    with pytest.raises(TypeError):
        prov.extra["columns"] = ("c",)  # type: ignore[index]
    with pytest.raises(TypeError):
        prov.compensation["mode"] = "triad"  # type: ignore[index]
    assert prov.extra["columns"] == ("a", "b") and prov.compensation["arms_m"] == ((1.0,),)
