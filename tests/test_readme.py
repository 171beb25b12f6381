"""The README's commands and examples are what the project actually does."""

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_python_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "README should hold a runnable python example"
    for i, block in enumerate(blocks):
        exec(compile(block, f"README.md[python block {i}]", "exec"), {})


def test_ci_runs_the_readme_test_command():
    commands = re.findall(r"```bash\n(.*?)```", README, flags=re.S)
    test_command = next(c.strip() for c in commands if "pytest" in c)
    assert test_command in (ROOT / ".ci" / "run").read_text()


def test_readme_main_job_uses_existing_configs():
    main_job = next(c for c in re.findall(r"```bash\n(.*?)```", README, flags=re.S) if "train.py" in c)
    for group, name in re.findall(r"\b(experiment|model)=([\w,]+)", main_job):
        for option in name.split(","):
            assert (ROOT / "configs" / group / f"{option}.yaml").exists(), f"{group}={option}"


#: The README's commands that take an input file, by the sample they name (lfd.samples writes the same names).
SAMPLE_NAMES = (
    "recording.csv",
    "recordings/",
    "arm.bag",
    "person.mp4",
    "cam01.mp4",
    "Calib.qca.txt",
    "scene=",
)
#: Commands that run for minutes, or need MediaPipe and the test videos: ``-m slow``.
SLOW = ("analyze_arm.py", ".mp4")


def readme_sample_commands() -> list[str]:
    """Every line of the README's bash blocks that runs a script or benchmark on an input file."""
    lines = [
        line.strip()
        for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S)
        for line in block.splitlines()
    ]
    return [
        line
        for line in lines
        if line.startswith(("python scripts/", "python benchmarks/")) and any(n in line for n in SAMPLE_NAMES)
    ]


SAMPLE_COMMANDS = readme_sample_commands()


def test_the_readme_names_every_sample_kind():
    joined = " ".join(SAMPLE_COMMANDS)
    assert len(SAMPLE_COMMANDS) >= 6 and all(name in joined for name in SAMPLE_NAMES), SAMPLE_COMMANDS


def _write_samples(folder: Path) -> Path:
    import lfd.samples

    lfd.samples.write_samples(folder)
    return folder


@pytest.fixture(scope="module")
def robot_samples(tmp_path_factory) -> Path:
    return _write_samples(tmp_path_factory.mktemp("readme") / "samples")


@pytest.fixture(scope="module")
def video_samples(tmp_path_factory, sports2d_video, pose2sim_demo, mediapipe_ok) -> Path:
    """The samples with their videos (the fixtures fetch the wheels they come from once, or skip)."""
    return _write_samples(tmp_path_factory.mktemp("readme_video") / "samples")


def _argv(command: str) -> list[str]:
    words = shlex.split(command.split("  #")[0])
    assert words[0] == "python", command
    return [sys.executable, str(ROOT / words[1]), *words[2:]]


@pytest.mark.parametrize(
    "command",
    [pytest.param(c, marks=pytest.mark.slow) if any(s in c for s in SLOW) else c for c in SAMPLE_COMMANDS],
    ids=[c.split(" ", 2)[1].rsplit("/", 1)[-1] + ":" + c.split(" ", 3)[2] for c in SAMPLE_COMMANDS],
)
def test_readme_command_runs_on_the_samples(command, request):
    """The command exactly as written, run in the samples folder (the README's names are the samples')."""
    folder = request.getfixturevalue("video_samples" if ".mp4" in command else "robot_samples")
    if "video_speed.py" in command:  # it times the full and the heavy pose model
        request.getfixturevalue("heavy_pose_model")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    if "teach.py" in command:  # a server: it must come up and print its URL; then it is stopped
        proc = subprocess.Popen(
            _argv(command), cwd=folder, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        try:
            lines = []
            while not any(" ready at " in line for line in lines) and (line := proc.stdout.readline()):
                lines.append(line)
        finally:
            proc.terminate()
            proc.wait(timeout=60)
        assert " ready at http://127.0.0.1:" in lines[-1], "".join(lines) + proc.stderr.read()[-2000:]
        return
    run = subprocess.run(_argv(command), cwd=folder, env=env, capture_output=True, text=True, timeout=1200)
    assert run.returncode == 0, f"{command}\n{run.stderr[-3000:]}"
    if "imitate.py" in command:
        newest = max((folder / "outputs" / "imitate").glob("*/summary.json"), key=lambda p: p.stat().st_mtime)
        summary = json.loads(newest.read_text())
        assert summary["limit_violations"] == 0 and summary["robot"] == "wam4"
        if (
            "refine.task=reach" in command
        ):  # the sample ends ~10 cm from the README's target, which is reached
            assert summary["refine"]["converged"] and summary["refine"]["task_error_m"] < 0.01, summary[
                "refine"
            ]
    if "analyze_arm.py" in command:
        assert any((folder / "outputs" / "analyze_arm").rglob("*.csv"))
    if "video_speed.py" in command:
        assert "fps" in run.stdout
