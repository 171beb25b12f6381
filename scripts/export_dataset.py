"""Export a dataset as LeRobot v3.0 or robomimic HDF5 (``configs/export_dataset.yaml``)::

    python scripts/export_dataset.py data=original format=lerobot out=data/original.lerobot
    python scripts/export_dataset.py data=original format=robomimic out=data/original.hdf5
    python scripts/export_dataset.py format=lerobot lerobot.codec=h264     # H.264 instead of AV1
    python scripts/export_dataset.py data=metaworld task=reach-v3 format=lerobot   # Meta-World demonstrations

The dataset is generated first when it is missing (like ``train.py``), otherwise verified
against its manifest. A progress bar shows the episodes; the time taken is printed.
``overwrite=true`` replaces only an earlier lfd export of the same format (never the dataset
or a folder holding it); a refused output or a bad dataset ends with one line on stderr, rc 2.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")
SUFFIX = {"lerobot": ".lerobot", "robomimic": ".hdf5"}


def export(cfg: DictConfig) -> Path:
    """Check the output, generate or verify ``cfg.data``'s dataset, then export it as ``cfg.format``."""
    from lfd.interop.export import FORMATS, export_dataset

    if cfg.format not in FORMATS:
        raise ValueError(f"format: expected one of {FORMATS}, got {cfg.format!r}")
    from lfd.interop.export import check_export_target

    datamodule = hydra.utils.instantiate(cfg.data)
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


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="export_dataset")
def main(cfg: DictConfig) -> str:
    try:
        return str(export(cfg))
    except (ValueError, FileExistsError, FileNotFoundError) as e:
        print(f"export_dataset: {e}", file=sys.stderr)
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
