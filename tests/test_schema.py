"""The JSON contracts of data-schemas/, checked with jsonschema: what sizefx writes and what a user gives it."""

from __future__ import annotations

import json
from importlib import resources

import numpy as np
import pytest

from sizefx.errors import ConfigError
from sizefx.io.schema import check_document, load_schema, schema_errors
from sizefx.levers import Levers, levers_from_preset, read_levers, write_levers

#: The contracts that are JSON Schema (the others are our HDF5/TOML formats, read by our own readers).
JSON_SCHEMAS = sorted(
    f"sizefx/{p.name.rsplit('-', 1)[0]}/{p.stem.rsplit('-', 1)[1]}"
    for p in resources.files("sizefx.schemas").iterdir()
    if p.name.endswith(".json") and "$schema" in json.loads(p.read_text("utf-8"))
)


def test_every_json_schema_is_valid_for_the_draft_it_declares():
    from jsonschema.validators import validator_for

    assert {"sizefx/levers/1", "sizefx/diagnosis/1", "sizefx/comparison/1"} <= set(JSON_SCHEMAS)
    for name in JSON_SCHEMAS:
        schema = load_schema(name)
        validator_for(schema, default=None).check_schema(schema)  # raises SchemaError when broken


def _good_levers(tmp_path):
    path = tmp_path / "lev.json"
    write_levers(path, levers_from_preset("high-precision", offset_m=(0.01, 0.0, 0.0)))
    return path, json.loads(path.read_text())


def _set(doc, key, value):
    doc[key] = value
    return doc


#: A user's bad levers file -> the JSON path and the words of its one-line message.
BAD_LEVERS = {
    "not an object": (lambda d: [1, 2, 3], "$ must be an object, got [1, 2, 3]"),
    "missing key": (lambda d: {k: v for k, v in d.items() if k != "d_z"}, "$.d_z: key 'd_z' is missing"),
    "short vector": (lambda d: _set(d, "r_y", [0.0, 0.02]), "$.r_y must be a list of 3 numbers, got [0.0, 0.02]"),
    "text in a vector": (lambda d: _set(d, "offset", [0.0, "1 mm", 0.0]), '$.offset[1] must be a number, got "1 mm"'),
    "unknown reference point": (
        lambda d: _set(d, "reference_point", "centre"),
        '$.reference_point must be one of "rotation-center", "triad", got "centre"',
    ),
    "other contract": (
        lambda d: _set(d, "schema", "sizefx/levers/2"),
        '$.schema must be "sizefx/levers/1", got "sizefx/levers/2"',
    ),
    "delay as text": (lambda d: _set(d, "accel_delay_s", "5e-4"), "$.accel_delay_s must be a number or null"),
    "delay as a flag": (lambda d: _set(d, "accel_delay_s", True), "$.accel_delay_s must be a number or null, got true"),
    "one tilt angle": (lambda d: _set(d, "tilt_arcsec", [3.0]), "$.tilt_arcsec must be a list of 2 numbers or null"),
    "two axes": (lambda d: _set(d, "axes", [[1, 0, 0], [0, 1, 0]]), "$.axes must be a list of 3 lists of 3 numbers"),
    "zero axis": (lambda d: _set(d, "axes", [[1, 0, 0], [0, 0, 0], [0, 0, 1]]), "$.axes[1] has length 0, not 1"),
}


@pytest.mark.parametrize("case", list(BAD_LEVERS))
def test_a_bad_levers_file_is_one_line_naming_the_file_the_json_path_and_the_problem(tmp_path, case):
    change, words = BAD_LEVERS[case]
    path, doc = _good_levers(tmp_path)
    path.write_text(json.dumps(change(doc)))
    with pytest.raises(ConfigError) as info:
        read_levers(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message
    assert words in message, message


@pytest.mark.parametrize(
    "text, words",
    [
        ("NaN", "NaN is not a JSON number"),
        ("Infinity", "Infinity is not a JSON number"),
        ("1e999", "the number 1e999 overflows a float"),
        ("1" + "0" * 400, "overflows a float"),
    ],
)
def test_numbers_json_cannot_hold_are_refused_where_they_enter(tmp_path, text, words):
    path, doc = _good_levers(tmp_path)
    path.write_text(json.dumps(doc).replace('"offset": [0.01', f'"offset": [{text}'))
    with pytest.raises(ConfigError, match=words):
        read_levers(path)


def test_a_good_levers_file_reads_back_with_its_extra_keys(tmp_path):
    path, doc = _good_levers(tmp_path)
    # a row within AXIS_LENGTH_TOLERANCE of unit length (typed to 4 decimals) is normalised
    doc["axes"] = [[1.0004, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    doc["note"] = "kept"
    path.write_text(json.dumps(doc))
    back = read_levers(path)
    np.testing.assert_allclose(back.arms_total[0], np.asarray(doc["r_x"]))
    np.testing.assert_allclose(back.axes, np.eye(3))
    assert back.extra["note"] == "kept" and back.extra["source"] == "preset high-precision"


def test_our_writer_checks_what_it_writes_and_writes_nothing_when_it_is_wrong(tmp_path):
    bad = Levers(arms_total=np.eye(3), offset=np.zeros(3), arms_triad=np.eye(3), extra={"triad_point": "middle"})
    with pytest.raises(AssertionError, match=r"\$\.triad_point must be one of \"normals\", \"x-accelerometer\""):
        write_levers(tmp_path / "lev.json", bad)
    assert not (tmp_path / "lev.json").exists()


def test_check_document_lists_every_problem_and_reads_numpy_values_as_json():
    doc = levers_from_preset("compact").to_json()
    doc["accel_delay_s"] = np.float64(5e-4)  # NumPy numbers are JSON numbers once written
    doc["r_x"] = np.array([0.01, 0.0, 0.0])
    doc["tilt_arcsec"] = (np.int64(-11), np.int64(-6))
    check_document(doc, "sizefx/levers/1")
    del doc["d_y"], doc["offset"]
    doc["r_z"] = [0.0, 0.0]
    assert schema_errors(doc, "sizefx/levers/1") == [
        "$.offset: key 'offset' is missing",
        "$.d_y: key 'd_y' is missing",
        "$.r_z must be a list of 3 numbers, got [0.0, 0.0]",
    ]
    with pytest.raises(
        AssertionError,
        match=r"document breaks sizefx/levers/1: \$\.offset: key 'offset' is missing; "
        r"\$\.d_y: key 'd_y' is missing; \$\.r_z must be",
    ):
        check_document(doc, "sizefx/levers/1")


def test_our_hdf5_and_toml_contracts_are_not_taken_for_json_schemas():
    with pytest.raises(ValueError, match="not a JSON Schema"):
        check_document({}, "sizefx/telemetry/1")
