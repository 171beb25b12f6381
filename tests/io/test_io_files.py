import hashlib
import json
import os

import numpy as np
import pytest

from lfd.io.files import (
    EXPORT_MARKER,
    DatasetError,
    OutputRefused,
    export_marker,
    json_bytes,
    npz_bytes,
    publish_output,
    read_export_marker,
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


def _publish_folder(target, text, **kw):
    with publish_output(target, "demo", **kw) as tmp:
        tmp.mkdir()
        (tmp / "a.txt").write_text(text)


def test_publish_output_marks_replaces_only_its_own_kind_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "out"
    _publish_folder(target, "one")
    assert read_export_marker(target) == export_marker("demo") and (target / "a.txt").read_text() == "one"
    with pytest.raises(FileExistsError, match="overwrite=True"):
        _publish_folder(target, "two")
    _publish_folder(target, "two", overwrite=True)
    assert (target / "a.txt").read_text() == "two" and sorted(os.listdir(tmp_path)) == ["out"]
    (target / EXPORT_MARKER).write_text("{not json")
    with pytest.raises(OutputRefused, match=f"no {EXPORT_MARKER} in it"):
        _publish_folder(target, "three", overwrite=True)
    with pytest.raises(OutputRefused, match="is or holds the source"):
        _publish_folder(tmp_path, "three", overwrite=True, protect=[target / "a.txt"])
    assert (target / "a.txt").read_text() == "two"


def test_publish_output_of_a_file_uses_the_kind_recorded_in_it(tmp_path):
    target = tmp_path / "f.bin"
    kind_of = lambda p: "demo" if p.read_bytes().startswith(b"DEMO") else None  # noqa: E731
    for data in (b"DEMO1", b"DEMO2"):
        with publish_output(target, "demo", overwrite=True, kind_of=kind_of) as tmp:
            tmp.write_bytes(data)
    assert target.read_bytes() == b"DEMO2" and sorted(os.listdir(tmp_path)) == ["f.bin"]
    target.write_bytes(b"user data")
    refused = pytest.raises(OutputRefused, match="no lfd marker in the file")
    with refused, publish_output(target, "demo", overwrite=True, kind_of=kind_of) as tmp:
        tmp.write_bytes(b"DEMO3")
    assert target.read_bytes() == b"user data"


def test_publish_output_leftovers(tmp_path):
    """A killed run's temporary sibling is removed by the next run, an output it had moved
    aside is put back first; one of a live process, or unmarked, is left alone."""
    target = tmp_path / "out"

    def leftover(pid, name, marker=True):
        folder = tmp_path / f".out.lfd-partial-{pid}-{name}"
        (folder / "replaced").mkdir(parents=True)
        (folder / "replaced" / "a.txt").write_text(name)
        if marker:
            (folder / EXPORT_MARKER).write_text(json.dumps({**export_marker("demo"), "partial": True}))
        return folder

    dead = leftover(4_194_305, "moved-aside")
    live = leftover(os.getppid(), "live")
    unmarked = leftover(4_194_305, "unmarked", marker=False)
    other_kind = leftover(4_194_305, "other")
    (other_kind / EXPORT_MARKER).write_text(json.dumps({**export_marker("other"), "partial": True}))
    with pytest.raises(FileExistsError):  # the moved-aside output is back at the target
        _publish_folder(target, "new")
    assert (target / "a.txt").read_text() == "moved-aside" and not dead.exists()
    assert live.exists() and unmarked.exists() and other_kind.exists()


def test_read_text_decodes_utf8_and_refuses_other_bytes(tmp_path):
    from lfd.io.files import read_text

    (tmp_path / "bom.txt").write_bytes("\ufeffa: 1\n".encode())
    assert read_text(tmp_path / "bom.txt") == "a: 1\n"
    (tmp_path / "latin1.txt").write_bytes("caf\xe9".encode("latin-1"))
    with pytest.raises(ValueError, match=r"latin1.txt: not UTF-8 text \(byte 3"):
        read_text(tmp_path / "latin1.txt")
    with pytest.raises(FileNotFoundError):
        read_text(tmp_path / "missing.txt")
