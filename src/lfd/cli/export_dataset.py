"""``lfd-export`` / ``python scripts/export_dataset.py``: a dataset as LeRobot v3.0 or robomimic HDF5.

The entry point; the repository's ``scripts/export_dataset.py`` documents the command and is a wrapper of
this module.
"""

from __future__ import annotations

import time
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.cli import configs_dir, run_app, user_errors
from lfd.cli.config import instantiate_node

#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()
SUFFIX = {"lerobot": ".lerobot", "robomimic": ".hdf5"}


def export(cfg: DictConfig) -> Path:
    """Check the output, generate or verify ``cfg.data``'s dataset, then export it as ``cfg.format``."""
    from lfd.interop.export import FORMATS, export_dataset

    if cfg.format not in FORMATS:
        raise ValueError(f"format: expected one of {FORMATS}, got {cfg.format!r}")
    from lfd.checks import check_int
    from lfd.interop.export import check_export_target

    check_int(cfg.limit, "limit", minimum=1, optional=True)  # before any data is generated
    datamodule = instantiate_node("data", cfg.data)
    from lfd.visuomotor.metaworld import MetaWorldDataModule

    if cfg.format != "lerobot" and isinstance(datamodule, MetaWorldDataModule):
        raise ValueError(f"format={cfg.format}: Meta-World demonstrations export to format=lerobot only")
    out = Path(cfg.out) if cfg.out else Path(f"{datamodule.path}{SUFFIX[cfg.format]}")
    check_export_target(datamodule.path, out, cfg.format, overwrite=cfg.overwrite)  # before any data
    datamodule.prepare_data()
    options = OmegaConf.to_container(cfg[cfg.format], resolve=True)
    t0 = time.perf_counter()
    export_dataset(
        datamodule.path,
        out,
        format=cfg.format,
        overwrite=cfg.overwrite,
        progress=cfg.progress,
        limit=cfg.limit,
        **options,
    )
    print(
        f"[lfd] {cfg.format} export of {datamodule.path} written to {out} in {time.perf_counter() - t0:.1f} s"
    )
    return out


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="export_dataset")
def main(cfg: DictConfig) -> str:
    with user_errors("export_dataset", (ValueError, FileExistsError, FileNotFoundError)):
        return str(export(cfg))


USAGE = """
lfd-export (python scripts/export_dataset.py): a dataset as LeRobot v3.0 or robomimic HDF5 (configs/export_dataset.yaml)
  data=quick|original|metaworld   format=lerobot|robomimic   out=PATH (default: beside the dataset)
  lerobot.codec=av1|h264   limit=N (the first N episodes)   overwrite=true (an earlier lfd export only)
The dataset is generated when missing, verified otherwise.
"""


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-export`` command (``python scripts/export_dataset.py``): ``--help`` prints :data:`USAGE`."""
    run_app(main, USAGE, argv)


if __name__ == "__main__":
    cli()
