"""Security and data safety: the `[video]` extra installs one OpenCV and no jax; output files say their
format; user text files of any bytes get one line naming them (docs/security.md).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import tomllib
from time_limits import deadline

import lfd.imitation
from lfd.dmp import DMP
from lfd.robots import load_robot

ROOT = Path(__file__).resolve().parents[1]
#: Distributions the `[video]` extra must never bring in: jax (MediaPipe's model-maker dependency) and a
#: second package providing `cv2` beside opencv-python-headless.
FORBIDDEN = {"jax", "jaxlib", "sounddevice", "opencv-contrib-python", "opencv-python", "mediapipe"}


def _name(requirement: str) -> str:
    return re.split(r"[\s<>=!~;\[]", requirement.strip(), maxsplit=1)[0].lower().replace("_", "-")


def _extra(name: str) -> list[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return project["optional-dependencies"][name]


def _closure(requirements: list[str]) -> set[str]:
    """Names of the installed distributions ``requirements`` pull in (their unconditional requirements)."""
    seen: set[str] = set()
    todo = [_name(r) for r in requirements]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            requires = metadata.requires(name) or []
        except metadata.PackageNotFoundError:
            continue
        todo += [_name(r) for r in requires if "extra ==" not in r]
    return seen


def test_video_extra_pulls_neither_jax_nor_a_second_opencv():
    video = _extra("video")
    assert not FORBIDDEN & {_name(r) for r in video}
    pulled = _closure(video)
    assert not FORBIDDEN & pulled, f"[video] pulls {sorted(FORBIDDEN & pulled)}"
    assert {"absl-py", "attrs", "flatbuffers", "protobuf"} <= pulled


def test_the_pose_solution_runs_on_the_video_extra_and_one_opencv():
    """MediaPipe installed by lfd-install-mediapipe imports and builds the pose estimator; cv2 is the headless one."""
    from lfd.human.video.estimator import load_pose_estimator

    providers = [d.metadata["Name"].lower() for d in metadata.distributions() if _provides_cv2(d)]
    assert providers == ["opencv-python-headless"], providers
    for name in ("jax", "jaxlib", "opencv-contrib-python"):
        with pytest.raises(metadata.PackageNotFoundError):
            metadata.version(name)
    estimator = load_pose_estimator(static=True)
    estimator.close()


def _provides_cv2(dist) -> bool:
    return any(str(f).startswith("cv2/__init__") for f in dist.files or [])


def test_readme_ci_and_docs_install_mediapipe_without_its_declared_dependencies():
    """Every command line installing the video extra is followed by lfd-install-mediapipe (pip check stays clean)."""
    ci = (ROOT / ".ci" / "run").read_text()
    step = "lfd-install-mediapipe"
    assert f'".[test,video]" && {step}' in ci
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "data" / "README.md"]
    install = 'pip install -e ".[video]"'
    lines = [(p, line) for p in pages for line in p.read_text().splitlines() if line.startswith(install)]
    assert any(p.name == "README.md" for p, _ in lines)
    bad = [f"{p.relative_to(ROOT)}: {line}" for p, line in lines if f'".[video]" && {step}' not in line]
    assert not bad, "install MediaPipe with lfd-install-mediapipe:\n" + "\n".join(bad)
    full = [line for line in (ROOT / "README.md").read_text().splitlines() if '".[test,video]"' in line]
    assert full and all(f'".[test,video]" && {step}' in line for line in full), full


def test_imitation_writes_its_dmp_as_json_under_a_json_name(tmp_path):
    """The imitation output `dmp.npz` was JSON: the name now says the format, and np.load is not invited."""
    robot = load_robot("wam4")
    t = np.linspace(0.0, 1.0, 40)
    q = robot.home.numpy() + np.outer(0.5 - 0.5 * np.cos(np.pi * t), [0.2, 0.1, 0.0, 0.4])
    fit = lfd.imitation.fit_dmp(SimpleNamespace(dmp=SimpleNamespace(n_basis=20)), robot, t, q, tmp_path)
    assert not list(tmp_path.glob("*.npz"))
    written = tmp_path / "dmp.json"
    assert json.loads(written.read_text())["type"] == "lfd.dmp.DMP"
    np.testing.assert_array_equal(DMP.load(written).weights_, fit.dmp.weights_)
    with pytest.raises(ValueError, match=r"\.json name"):
        fit.dmp.save(tmp_path / "dmp.npz")


@pytest.mark.slow
def test_pip_resolves_the_video_extra_to_one_opencv_and_no_jax(tmp_path):
    """What pip would install for `pip install -e ".[video]"` on an empty environment (resolution only)."""
    report = tmp_path / "report.json"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--dry-run", "--ignore-installed", "--quiet"]
        + ["--report", str(report), "-e", f"{ROOT}[video]"],
        check=True,
        timeout=600,
    )
    names = {item["metadata"]["name"].lower() for item in json.loads(report.read_text())["install"]}
    assert not FORBIDDEN & names, sorted(FORBIDDEN & names)
    assert "opencv-python-headless" in names and "absl-py" in names


@pytest.mark.parametrize("name", ["calibration.json", "calibration.toml", "scene.yaml", "recording.csv"])
def test_binary_user_files_get_one_line_naming_them(tmp_path, name):
    from lfd.human.multiview import read_calibration
    from lfd.human.readers import read_skeleton
    from lfd.teach.scene import load_scene

    path = tmp_path / name
    path.write_bytes(bytes(range(256)) * 4)
    reader = {"calibration": read_calibration, "scene": load_scene, "recording": read_skeleton}[path.stem]
    with pytest.raises(ValueError, match="not UTF-8") as info:
        reader(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


# --- YAML: one safe loader for every user YAML file (scenario, teach scene, Hydra overrides) -------------


def _alias_bomb(depth: int = 9, width: int = 10) -> str:
    """``depth`` levels of ``width`` aliases each: a few hundred bytes standing for width**depth values."""
    lines = ["a0: &a0 [1.0]"]
    for i in range(1, depth + 1):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("a: &x 1\nb: *x\n", r"line 2, column 4: alias \*x refused"),
        ("objects: [1]\nplacements: [2]\nobjects: [3]\n", r"line 3, column 1: duplicate key 'objects'"),
        ("a:\n  b: 1\n  c: 2\n  b: 3\n", r"line 4, column 3: duplicate key 'b'"),
        ("[" * 100_000, r"nested more than \d+ deep"),
        ("x: !!python/object/apply:os.system ['true']\n", r"could not determine a constructor"),
    ],
    ids=["alias", "duplicate-top-level", "duplicate-nested", "deep", "python-tag"],
)
def test_yaml_loader_refuses_aliases_duplicate_keys_and_deep_nesting(tmp_path, text, expected):
    from lfd.io.files import YamlError, read_yaml

    path = tmp_path / "user.yaml"
    path.write_text(text)
    with deadline(10), pytest.raises(YamlError, match=expected) as info:
        read_yaml(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


def test_yaml_alias_bomb_is_refused_at_once_and_plain_yaml_still_loads(tmp_path):
    from lfd.io.files import YamlError, read_yaml

    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_alias_bomb() + "mass: *a9\n")
    assert bomb.stat().st_size < 600
    with deadline(10), pytest.raises(YamlError, match=r"alias \*a0 refused") as info:
        data = read_yaml(bomb)
        str(data)  # with aliases allowed: 10**9 values, unbounded work
    assert len(str(info.value)) < 300
    plain = tmp_path / "plain.yaml"
    plain.write_text("a: [1, 2]\nb: {c: 3, d: [x, y]}\n'1': one\n1: int one\n")
    assert read_yaml(plain) == {"a": [1, 2], "b": {"c": 3, "d": ["x", "y"]}, "1": "one", 1: "int one"}
    big = tmp_path / "big.yaml"
    big.write_bytes(b"#" * 2048)
    with pytest.raises(YamlError, match="2048 bytes; a YAML file has at most 1024"):
        read_yaml(big, max_bytes=1024)


def test_show_does_bounded_work_on_huge_values():
    from lfd.io.files import show

    calls = []

    class Counted:
        def __repr__(self):
            calls.append(1)
            return "c"

    shared = [Counted()] * 10
    huge = [[[[shared] * 10] * 10] * 10] * 10  # 10**5 leaves, like an expanded alias
    text = show(huge)
    assert len(text) <= 80 and len(calls) < 100
    assert show(10**5000) == "<int>" and "..." in show("x" * 10**6) and len(show("x" * 10**6)) <= 80


def test_teach_scene_and_grid_overrides_use_the_safe_loader(tmp_path):
    from lfd.io.files import YamlError
    from lfd.teach.scene import load_scene
    from lfd.visuomotor.eval.grid import collect

    scene = tmp_path / "scene.yaml"
    scene.write_text(
        "goal: {center: [0.5, 0, 0.2], radius: 0.05}\ngoal: {center: [0.4, 0, 0.2], radius: 0.05}\n"
    )
    with pytest.raises(YamlError, match=f"{re.escape(str(scene))}: .*duplicate key 'goal'"):
        load_scene(scene)
    scene.write_text(_alias_bomb() + "obstacles: *a9\n")
    with deadline(10), pytest.raises(YamlError, match="alias"):
        load_scene(scene)
    job = tmp_path / "sweep" / "0" / ".hydra"
    job.mkdir(parents=True)
    (job / "overrides.yaml").write_text("- &s seed=1\n- *s\n")
    with pytest.raises(YamlError, match="overrides.yaml: .*alias"):
        collect(tmp_path / "sweep")


# --- get_pose_model.py --dest: never replaces what lfd did not write ---------------------------------------


@pytest.fixture
def pose_script(monkeypatch, tmp_path):
    """scripts/get_pose_model.py as a module, with a stand-in model instead of the npm download."""
    import hashlib
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "get_pose_model_test", ROOT / "scripts" / "get_pose_model.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    model = b"tflite stand-in " * 64
    monkeypatch.setattr(module, "HEAVY_MODEL_BYTES", len(model))
    monkeypatch.setattr(module, "HEAVY_MODEL_SHA256", hashlib.sha256(model).hexdigest())
    fetched = []

    def fetch(folder: Path) -> Path:
        fetched.append(folder)
        (folder / "pose_landmark_heavy.tflite").write_bytes(model)
        return folder / "pose_landmark_heavy.tflite"

    monkeypatch.setattr(module, "fetch", fetch)
    return SimpleNamespace(module=module, model=model, fetched=fetched)


def test_get_pose_model_dest_refuses_a_file_it_did_not_write(pose_script, tmp_path, monkeypatch, capsys):
    dest = tmp_path / "notes.txt"
    dest.write_text("my notes")
    monkeypatch.setattr(sys, "argv", ["get_pose_model.py", "--dest", str(dest)])
    with pytest.raises(SystemExit) as info:
        pose_script.module.main()
    assert info.value.code == 2 and dest.read_text() == "my notes" and not pose_script.fetched
    err = capsys.readouterr().err
    assert err.startswith(f"get_pose_model: refusing to replace {dest}: it is another file (8 bytes")
    assert err.count("\n") == 1
    folder, link = tmp_path / "folder", tmp_path / "link.tflite"
    folder.mkdir()
    link.symlink_to(dest)
    for path, what in ((folder, "a folder"), (link, "a symbolic link")):
        with pytest.raises(ValueError, match=f"refusing to replace .*: it is {what}"):
            pose_script.module.provision(path)
    assert dest.read_text() == "my notes" and list(folder.iterdir()) == []


def test_get_pose_model_dest_writes_a_new_file_and_keeps_a_verified_copy(pose_script, tmp_path, capsys):
    dest = tmp_path / "models" / "heavy.tflite"
    pose_script.module.provision(dest)
    assert dest.read_bytes() == pose_script.model and len(pose_script.fetched) == 1
    assert sorted(p.name for p in dest.parent.iterdir()) == ["heavy.tflite"]  # no leftovers
    before = dest.stat().st_mtime_ns
    pose_script.module.provision(dest)
    assert len(pose_script.fetched) == 1 and dest.stat().st_mtime_ns == before
    assert "already at" in capsys.readouterr().out
