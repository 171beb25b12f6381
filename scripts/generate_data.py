"""Generate (or verify) a dataset without training, optionally one shard of it.

Uses the same Hydra config as ``train.py``, so every ``data.*`` override applies::

    python scripts/generate_data.py data=original                       # whole dataset
    python scripts/generate_data.py data=original data.shard=0 data.num_shards=4   # machine / array task 0
    python scripts/generate_data.py data=original +merge_shards=4       # join the 4 shards

A merged dataset is byte-identical to an unsharded run (``lfd.visuomotor.data.merge_shards``).
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="train")
def main(cfg: DictConfig) -> None:
    from lfd.visuomotor.data import dataset_dir, merge_shards

    n_merge = cfg.get("merge_shards")
    if n_merge:
        root, name = cfg.data.root, cfg.data.name
        shards = [dataset_dir(root, name, i, n_merge) for i in range(n_merge)]
        merge_shards(shards, dataset_dir(root, name))
        print(f"[lfd] merged {n_merge} shards into {dataset_dir(root, name)}")
        return
    datamodule = hydra.utils.instantiate(cfg.data)
    datamodule.prepare_data()
    print(f"[lfd] dataset ready: {datamodule.path}")


if __name__ == "__main__":
    main()
