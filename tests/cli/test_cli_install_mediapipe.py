"""lfd-install-mediapipe: MediaPipe's wheel rewritten with four requirements left out of its metadata, every other
file unchanged, a RECORD that matches; and ``pip check`` clean where the video extra is installed."""

from __future__ import annotations

import base64
import csv
import hashlib
import io
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from lfd.cli.install_mediapipe import LEFT_OUT, cli, rewrite_wheel
from tests.conftest import require

METADATA = """Metadata-Version: 2.1
Name: mediapipe
Version: 0.10.14
Requires-Dist: absl-py
Requires-Dist: attrs >=19.1.0
Requires-Dist: jax
Requires-Dist: jaxlib
Requires-Dist: matplotlib
Requires-Dist: opencv-contrib-python
Requires-Dist: protobuf <5,>=4.25.3
Requires-Dist: sounddevice >=0.4.4

MediaPipe's description, which mentions Requires-Dist: jax in prose.
"""


def _wheel(folder: Path) -> Path:
    path = folder / "mediapipe-0.10.14-cp311-cp311-manylinux_2_17_x86_64.whl"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("mediapipe/__init__.py", b"__version__ = '0.10.14'\n")
        z.writestr("mediapipe/modules/pose.tflite", bytes(range(256)) * 4)
        z.writestr("mediapipe-0.10.14.dist-info/METADATA", METADATA)
        z.writestr("mediapipe-0.10.14.dist-info/WHEEL", "Wheel-Version: 1.0\n")
        z.writestr("mediapipe-0.10.14.dist-info/RECORD", "stale,,\n")
    return path


def test_the_four_requirements_are_left_out_and_nothing_else_changes(tmp_path):
    original = _wheel(tmp_path)
    (tmp_path / "out").mkdir()
    out = rewrite_wheel(original, tmp_path / "out")
    assert out.name == "mediapipe-0.10.14+lfd-cp311-cp311-manylinux_2_17_x86_64.whl"
    with zipfile.ZipFile(original) as a, zipfile.ZipFile(out) as b:
        names = b.namelist()
        assert "mediapipe-0.10.14+lfd.dist-info/METADATA" in names
        assert not any(n.startswith("mediapipe-0.10.14.dist-info/") for n in names)
        for name in ("mediapipe/__init__.py", "mediapipe/modules/pose.tflite"):
            assert b.read(name) == a.read(name)
        metadata = b.read("mediapipe-0.10.14+lfd.dist-info/METADATA").decode()
        record = b.read("mediapipe-0.10.14+lfd.dist-info/RECORD").decode()
        contents = {n: b.read(n) for n in names}
    requires = [
        line.split(":", 1)[1].strip() for line in metadata.splitlines() if line.startswith("Requires-Dist:")
    ]
    assert requires == ["absl-py", "attrs >=19.1.0", "matplotlib", "protobuf <5,>=4.25.3"]
    assert "Version: 0.10.14+lfd" in metadata.splitlines()
    assert "mentions Requires-Dist: jax in prose" in metadata  # the description is not touched
    rows = list(csv.reader(io.StringIO(record)))
    assert {r[0] for r in rows} == set(names)
    for path, digest, size in rows:
        if path.endswith("RECORD"):
            assert digest == size == ""
            continue
        data = contents[path]
        assert size == str(len(data))
        assert (
            digest
            == "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        )
    assert set(LEFT_OUT) == {"jax", "jaxlib", "sounddevice", "opencv-contrib-python"}


def test_a_file_that_is_no_mediapipe_wheel_is_one_line(tmp_path, capsys):
    not_a_wheel = tmp_path / "mediapipe-0.10.14.tar.gz"
    not_a_wheel.write_bytes(b"x")
    with pytest.raises(ValueError, match=r"wheel=.*: expected a wheel file"):
        rewrite_wheel(not_a_wheel, tmp_path)
    other = tmp_path / "numpy-2.0-cp311-cp311-linux_x86_64.whl"
    other.write_bytes(b"x")
    with pytest.raises(SystemExit) as exit_:
        cli(["--wheel", str(other)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lfd-install-mediapipe: --wheel=") and "expected a mediapipe-0.10.14-*.whl" in err
    assert len(err.splitlines()) == 1


def test_pip_check_is_clean():
    """Every installed distribution's requirements hold (MediaPipe's too, when the video extra is installed
    with lfd-install-mediapipe). Outside CI an environment with other packages may skip, with pip's first
    complaint; under LFD_REQUIRE_ALL_TESTS=1 (.ci/run) it fails."""
    run = subprocess.run([sys.executable, "-m", "pip", "check"], capture_output=True, text=True, timeout=300)
    first = (run.stdout.strip().splitlines() or [run.stderr.strip()])[0]
    require(
        run.returncode == 0,
        f"a clean pip check ({first})",
        'pip install -c .ci/constraints.txt -e ".[test,video]" && lfd-install-mediapipe',
    )


def test_a_corrupt_wheel_and_a_failed_pip_are_one_line(tmp_path, capsys, monkeypatch):
    import subprocess

    corrupt = tmp_path / "mediapipe-0.10.14-cp311-cp311-manylinux_2_17_x86_64.whl"
    corrupt.write_bytes(b"not a zip file")
    with pytest.raises(SystemExit) as exit_:
        cli(["--wheel", str(corrupt)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"lfd-install-mediapipe: {corrupt}:") and len(err.splitlines()) == 1

    def failing_pip(*args):
        raise subprocess.CalledProcessError(1, [sys.executable, "-m", "pip", *args])

    monkeypatch.setattr("lfd.cli.install_mediapipe._pip", failing_pip)
    with pytest.raises(SystemExit) as exit_:
        cli([])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err == "lfd-install-mediapipe: pip download failed (exit 1); see pip's message above"
