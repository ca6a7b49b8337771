"""The one JSON writer: null plus the reason for every value that is not finite, never a NaN token."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bwbench.data import strict_json


def test_values_that_are_not_finite_are_null_with_where_and_why():
    value = {
        "mse": math.inf,
        "f_err": -math.inf,
        "params": {"a/b": np.float32(2.5), "c~": np.nan},
        "trace": np.array([1.0, np.inf]),
        "x/y": math.inf,
        "n": np.int64(7),
        "ok": np.bool_(True),
        "name": "x",
    }
    text = strict_json.dumps(value, why={"mse": "the model blows up", "trace": "a blow-up mid-run"})
    parsed = strict_json.loads(text)
    assert parsed["mse"] is None and parsed["f_err"] is None and parsed["params"] == {"a/b": 2.5, "c~": None}
    assert parsed["trace"] == [1.0, None] and parsed["n"] == 7 and parsed["ok"] is True and parsed["name"] == "x"
    # RFC 6901 pointers ("~" in a key written "~0", "/" written "~1"), the reasons given by top-level key
    assert parsed["not_finite"] == {
        "/mse": "+inf: the model blows up",
        "/f_err": "-inf",
        "/params/c~0": "nan",
        "/trace/1": "+inf: a blow-up mid-run",
        "/x~1y": "+inf",
    }
    assert (
        strict_json.dumps({"x": math.nan}, why="one reason for all")
        == '{"x": null, "not_finite": {"/x": "nan: one reason for all"}}'
    )


def test_finite_documents_are_written_as_json_writes_them():
    value = {"b": [1, 2.5, True, None], "a": {"u": "N·s/mm"}, "t": (1, 2)}
    assert strict_json.dumps(value, indent=2) == json.dumps(value, indent=2)
    assert strict_json.dumps(value, canonical=True) == json.dumps(
        value, sort_keys=True, separators=(",", ":"), ensure_ascii=False
    )


def test_canonical_text_for_the_store_has_null_only():
    assert strict_json.dumps({"b": math.inf, "a": 1.0}, canonical=True) == '{"a":1.0,"b":null}'
    assert strict_json.dumps([math.nan, 1], why="ignored: a list has no place for it") == "[null, 1]"


def test_a_document_that_has_its_own_not_finite_key_is_refused_not_overwritten():
    with pytest.raises(ValueError, match="has a 'not_finite' key"):
        strict_json.dumps({"not_finite": 1, "x": math.inf})
    assert strict_json.loads(strict_json.dumps({"not_finite": 1, "x": 2.0})) == {"not_finite": 1, "x": 2.0}


def test_a_value_json_cannot_hold_raises_and_write_leaves_no_file(tmp_path):
    with pytest.raises(TypeError):
        strict_json.dumps({"x": object()})
    with pytest.raises(TypeError):
        strict_json.write(tmp_path / "x.json", {"x": object()})
    assert not (tmp_path / "x.json").exists()
    strict_json.write(tmp_path / "y.json", {"x": -math.inf})
    assert strict_json.loads((tmp_path / "y.json").read_text()) == {"x": None, "not_finite": {"/x": "-inf"}}


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
def test_the_strict_reader_refuses_what_json_loads_accepts(token):
    assert json.loads(f'{{"x": {token}}}')  # Python's reader takes it...
    with pytest.raises(ValueError, match=f"not strict JSON: {token} token"):
        strict_json.loads(f'{{"x": {token}}}')


def test_an_output_is_replaced_whole_or_not_at_all(tmp_path):
    """Interrupted while writing (KeyboardInterrupt inside the block): the old file stays, no partial file
    is left; through a symlink the file it names is written and the link kept."""
    import os

    import pytest

    from bwbench.data import strict_json
    from bwbench.data.output_paths import replaced_whole

    target = tmp_path / "r.json"
    target.write_text("old\n")
    with pytest.raises(KeyboardInterrupt):
        with replaced_whole(target) as partial:
            partial.write_text("half")
            raise KeyboardInterrupt
    assert target.read_text() == "old\n" and sorted(os.listdir(tmp_path)) == ["r.json"]
    (tmp_path / "link.json").symlink_to(target)
    strict_json.write(tmp_path / "link.json", {"a": 1})
    assert (tmp_path / "link.json").is_symlink() and strict_json.loads(target.read_text()) == {"a": 1}
    assert sorted(os.listdir(tmp_path)) == ["link.json", "r.json"]
