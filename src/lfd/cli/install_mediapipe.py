"""``lfd-install-mediapipe``: install MediaPipe 0.10.14 for the ``[video]`` extra so that ``pip check`` holds.

lfd's video pipeline uses MediaPipe's pose solution, whose models ship in its wheel. MediaPipe
0.10.14 declares four requirements that the pose solution never imports: ``jax`` and ``jaxlib``
(about 100 MB), ``sounddevice`` (audio tasks) and ``opencv-contrib-python``, a second distribution
of the ``cv2`` module that would overwrite lfd's ``opencv-python-headless`` (and needs libGL).
Installing MediaPipe with ``pip install --no-deps`` leaves them out but ``pip check`` then reports
them as broken requirements. This command downloads MediaPipe's own wheel with pip (your index
and pip settings), writes a copy whose metadata lists every requirement except those four, with
the version ``0.10.14+lfd`` (a local version label: the code is MediaPipe's, the metadata is not
quite), and installs that copy without dependencies; the rest of MediaPipe's requirements (absl-py,
attrs, flatbuffers, protobuf < 5, numpy, matplotlib) are the ``[video]`` extra's and lfd's own::

    pip install ".[video]" && lfd-install-mediapipe          # or: python -m lfd.cli.install_mediapipe
    lfd-install-mediapipe --wheel mediapipe-0.10.14-....whl  # a wheel already downloaded

Only the wheel's ``*.dist-info/`` metadata is changed (``METADATA``, ``RECORD``, the folder name);
every other file is copied byte for byte.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

#: The MediaPipe release whose pose solution lfd uses (``lfd.human.video``).
VERSION = "0.10.14"
#: The local version label of the rewritten wheel.
LOCAL = "lfd"
#: MediaPipe's declared requirements that the pose solution does not import (module docstring).
LEFT_OUT = ("jax", "jaxlib", "sounddevice", "opencv-contrib-python")


def _name(requirement: str) -> str:
    """The normalised project name of a ``Requires-Dist`` value (PEP 503)."""
    name = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement)
    return re.sub(r"[-_.]+", "-", name.group(1)).lower() if name else ""


def _record_hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def rewrite_wheel(
    wheel: Path, out_dir: Path, left_out: tuple[str, ...] = LEFT_OUT, local: str = LOCAL
) -> Path:
    """A copy of ``wheel`` in ``out_dir`` whose metadata leaves out the requirements ``left_out``
    and whose version carries the local label ``local`` (``0.10.14`` -> ``0.10.14+lfd``); returns
    its path. The other files are copied unchanged and ``RECORD`` is written for the new contents.

    Raises:
        ValueError: ``wheel`` is not a wheel with one ``*.dist-info/METADATA`` (one line naming it).
    """
    parts = wheel.name.split("-")
    if wheel.suffix != ".whl" or len(parts) < 5:
        raise ValueError(f"wheel={wheel}: expected a wheel file (name-version-...-platform.whl)")
    name, version = parts[0], parts[1]
    new_version = f"{version.split('+')[0]}+{local}"
    old_info, new_info = f"{name}-{version}.dist-info/", f"{name}-{new_version}.dist-info/"
    drop = {_name(r) for r in left_out}
    with zipfile.ZipFile(wheel) as src:
        if f"{old_info}METADATA" not in src.namelist():
            raise ValueError(f"wheel={wheel}: expected {old_info}METADATA in it")
        out = out_dir / "-".join([name, new_version, *parts[2:]])
        records = []
        with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as dst:
            for info in src.infolist():
                path = info.filename
                if path == f"{old_info}RECORD":
                    continue
                data = src.read(info)
                if path.startswith(old_info):
                    path = new_info + path[len(old_info) :]
                    if path == f"{new_info}METADATA":
                        lines = data.decode("utf-8").split("\n")
                        kept = [
                            f"Version: {new_version}" if line.startswith("Version:") else line
                            for line in lines
                            if not (line.startswith("Requires-Dist:") and _name(line[14:]) in drop)
                        ]
                        data = "\n".join(kept).encode("utf-8")
                entry = zipfile.ZipInfo(path, date_time=info.date_time)
                entry.external_attr, entry.compress_type = info.external_attr, zipfile.ZIP_DEFLATED
                dst.writestr(entry, data)
                records.append(f"{path},{_record_hash(data)},{len(data)}")
            records.append(f"{new_info}RECORD,,")
            dst.writestr(f"{new_info}RECORD", "\n".join(records) + "\n")
    return out


def _pip(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "pip", *args], check=True)


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-install-mediapipe`` command (module docstring)."""
    parser = argparse.ArgumentParser(
        prog="lfd-install-mediapipe",
        description=f"install MediaPipe {VERSION} for lfd's [video] extra without {', '.join(LEFT_OUT)} "
        "(its wheel with those requirements left out of the metadata, so that pip check holds)",
    )
    parser.add_argument(
        "--wheel", type=Path, help=f"a downloaded mediapipe-{VERSION} wheel (default: pip download)"
    )
    args = parser.parse_args(argv)
    try:
        _install(parser, args.wheel)
    except subprocess.CalledProcessError as e:
        parser.exit(
            2,
            f"lfd-install-mediapipe: pip {e.cmd[3]} failed (exit {e.returncode}); see pip's message above\n",
        )


def _install(parser: argparse.ArgumentParser, wheel: Path | None) -> None:
    with tempfile.TemporaryDirectory(prefix="lfd-mediapipe-") as tmp:
        if wheel is None:
            _pip("download", "--no-deps", "--only-binary=:all:", f"mediapipe=={VERSION}", "-d", tmp)
            wheel = next(Path(tmp).glob("mediapipe-*.whl"))
        elif not wheel.is_file() or not wheel.name.startswith(f"mediapipe-{VERSION}-"):
            parser.exit(
                2, f"lfd-install-mediapipe: --wheel={wheel}: expected a mediapipe-{VERSION}-*.whl file\n"
            )
        try:
            rewritten = rewrite_wheel(wheel, Path(tmp))
        except (ValueError, zipfile.BadZipFile) as e:
            parser.exit(2, f"lfd-install-mediapipe: {wheel}: {e}\n")
        _pip("install", "--no-deps", "--force-reinstall", str(rewritten))
    print(f"[lfd] installed {rewritten.name} (left out of its requirements: {', '.join(LEFT_OUT)})")


if __name__ == "__main__":
    cli()
