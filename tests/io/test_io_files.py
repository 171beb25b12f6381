import hashlib
import json
import os

import numpy as np
import pytest

from lfd.io.files import (
    DatasetError,
    json_bytes,
    npz_bytes,
    read_json,
    sha256_file,
    write_bytes_atomic,
    write_json_atomic,
    write_npz_atomic,
    write_text_atomic,
)


def test_atomic_write_replaces_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "sub" / "a.txt"
    write_text_atomic(path, "old")
    write_bytes_atomic(path, b"new")
    assert path.read_bytes() == b"new"
    assert sorted(os.listdir(path.parent)) == ["a.txt"]
    assert oct(path.stat().st_mode & 0o777) == oct(0o644)


def test_failed_write_keeps_the_old_file(tmp_path):
    path = tmp_path / "a.txt"
    write_text_atomic(path, "old")

    with pytest.raises(TypeError):
        write_bytes_atomic(path, "not bytes")  # type: ignore[arg-type]
    assert path.read_text() == "old"
    assert sorted(os.listdir(tmp_path)) == ["a.txt"]


def test_npz_bytes_are_deterministic_and_readable(tmp_path):
    arrays = {"b": np.arange(6.0).reshape(2, 3), "a": np.array([1, 2], np.int16)}
    first, second = npz_bytes(arrays), npz_bytes(dict(arrays))
    assert first == second
    write_npz_atomic(tmp_path / "x.npz", arrays)
    with np.load(tmp_path / "x.npz", allow_pickle=False) as loaded:
        assert list(loaded.keys()) == ["b", "a"]
        np.testing.assert_array_equal(loaded["b"], arrays["b"])
        assert loaded["a"].dtype == np.int16
    assert sha256_file(tmp_path / "x.npz") == hashlib.sha256(first).hexdigest()


def test_json_round_trip_and_errors_name_the_file(tmp_path):
    write_json_atomic(tmp_path / "m.json", {"b": 1, "a": [1.5]})
    assert (tmp_path / "m.json").read_bytes() == json_bytes({"a": [1.5], "b": 1})
    assert read_json(tmp_path / "m.json") == json.loads(json_bytes({"a": [1.5], "b": 1}))
    with pytest.raises(DatasetError, match="missing file .*nope.json"):
        read_json(tmp_path / "nope.json")
    (tmp_path / "bad.json").write_bytes(b"\xff{")
    with pytest.raises(DatasetError, match="corrupt JSON file .*bad.json"):
        read_json(tmp_path / "bad.json")
