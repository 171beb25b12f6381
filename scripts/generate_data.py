"""Generate (or verify) a dataset without training, optionally one shard of it.

Uses the same Hydra config as ``train.py``, so every ``data.*`` override applies::

    python scripts/generate_data.py data=original                       # whole dataset
    python scripts/generate_data.py data=original data.shard=0 data.num_shards=4   # machine / array task 0
    python scripts/generate_data.py data=original +merge_shards=4       # join the 4 shards

A merged dataset is byte-identical to an unsharded run (``lfd.visuomotor.data.merge_shards``); the
merge goes into a new folder only (an existing dataset is never written into). A refused merge, a bad
setting or a corrupt dataset ends with one line on stderr, exit status 2.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="train")
def main(cfg: DictConfig) -> None:
    from lfd.cli import user_errors

    with user_errors("generate_data", (ValueError, FileExistsError, FileNotFoundError)):
        run(cfg)


def run(cfg: DictConfig) -> None:
    """Merge ``+merge_shards=N`` shards, or generate (or verify) ``cfg.data``'s dataset or shard."""
    from lfd.visuomotor.data import dataset_dir, merge_shards

    n_merge = cfg.get("merge_shards")
    if n_merge:
        root, name = cfg.data.root, cfg.data.name
        shards = [dataset_dir(root, name, i, n_merge) for i in range(n_merge)]
        merge_shards(shards, dataset_dir(root, name))
        print(f"[lfd] merged {n_merge} shards into {dataset_dir(root, name)}")
        return
    from lfd.cli.config import instantiate_node

    datamodule = instantiate_node("data", cfg.data)
    datamodule.prepare_data()
    print(f"[lfd] dataset ready: {datamodule.path}")


if __name__ == "__main__":
    main()
