"""The README's commands and examples are what the project actually does."""

import re
from pathlib import Path

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
