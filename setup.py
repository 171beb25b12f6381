"""Build step of lfd's package (the rest of the build is declared in pyproject.toml).

The repository's ``configs/`` folder is the source of truth of the commands' configs. A wheel (and a
non-editable ``pip install .``) carries a copy as ``lfd/configs``, so that ``lfd-train`` and the other
commands run from any folder (:func:`lfd.cli.configs_dir`); an editable install reads ``configs/``
itself and gets no copy.
"""

from __future__ import annotations

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

#: The repository's configs (copied into the sdist by MANIFEST.in).
CONFIGS = Path(__file__).resolve().parent / "configs"


class BuildPyWithConfigs(build_py):
    """``build_py`` that also copies ``configs/**/*.yaml`` to ``<build>/lfd/configs/``."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        if not (CONFIGS / "train.yaml").is_file():
            raise FileNotFoundError(f"configs: expected the repository's configs folder at {CONFIGS}")
        target = Path(self.build_lib) / "lfd" / "configs"
        for source in sorted(CONFIGS.rglob("*.yaml")):
            destination = target / source.relative_to(CONFIGS)
            self.mkpath(str(destination.parent))
            self.copy_file(str(source), str(destination))


setup(cmdclass={"build_py": BuildPyWithConfigs})
