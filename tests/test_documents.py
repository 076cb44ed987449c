"""JSON documents written by :mod:`sizefx.io.documents`: whole (``write_json``) or with one list streamed."""

from __future__ import annotations

import json

import pytest

from sizefx.io.documents import write_json, write_json_streamed


def test_a_streamed_document_is_the_whole_one_in_the_one_writers_form(tmp_path):
    """The head is ``write_json``'s text; the list's elements, given as JSON text one at a time, read
    back as the list (none too: an empty list)."""
    records = [{"input": f"r{k}.h5", "value": k / 3, "ok": k != 1} for k in range(3)]
    doc = {"schema": "sizefx/batch/1", "options": {"rate_hz": 1.5e3}, "records": []}
    path = write_json_streamed(tmp_path / "m.json", doc, "records", (json.dumps(r) for r in records))
    assert json.loads(path.read_text()) == {**doc, "records": records}
    head = write_json(tmp_path / "whole.json", doc).read_text()
    assert path.read_text().startswith(head[: -len("]\n}\n")]) and path.read_text().endswith("\n  ]\n}\n")
    assert json.loads(write_json_streamed(tmp_path / "e.json", doc, "records", iter(())).read_text()) == doc
    with pytest.raises(ValueError, match="last entry"):
        write_json_streamed(tmp_path / "bad.json", {"records": [], "after": 1}, "records", iter(()))
