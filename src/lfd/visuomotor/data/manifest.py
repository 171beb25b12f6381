"""``manifest.json``: what a finished dataset (or shard) holds, and its verification.

The manifest is written last, after every episode file and ``stats.json``; it records
the generator config, the code version, the episode and discard counts and the SHA-256
of every other file. :func:`verify_dataset` refuses anything that does not match it.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from lfd.io.files import DatasetError, read_json, sha256_file, write_json_atomic
from lfd.sim.expert import DISCARD_REASONS
from lfd.visuomotor.data.config import FORMAT_VERSION, GeneratorConfig
from lfd.visuomotor.data.episodes import EPISODE_DIR, SPLITS, EpisodeRecord, episode_path
from lfd.visuomotor.data.stats import compute_stats

MANIFEST = "manifest.json"
STATS = "stats.json"
FORMAT_NAME = "lfd-reach-demonstrations"


def write_manifest(
    out_dir: Path, cfg: GeneratorConfig, indices: Sequence[int], *, shard: int | None, num_shards: int
) -> dict[str, Any]:
    """Check the episode files ``indices`` in ``out_dir``, write ``stats.json`` (full
    datasets only) and then ``manifest.json``; returns the manifest."""
    records = [EpisodeRecord.load(out_dir / episode_path(i)) for i in indices]
    cfg_sha = cfg.sha256()
    versions = {str(r.arrays["code_version"]) for r in records}
    for r in records:
        if str(r.arrays["config_sha256"]) != cfg_sha:
            raise DatasetError(f"{r.path} was generated with a different config")
    if len(versions) > 1:
        raise DatasetError(
            f"{out_dir}: episodes come from several code versions {sorted(versions)}; regenerate"
        )
    files = [episode_path(i) for i in indices]
    if shard is None:
        write_json_atomic(out_dir / STATS, compute_stats([r for r in records if r.split == "train"]))
        files.append(STATS)
    splits = Counter(r.split for r in records)
    discarded = Counter()
    for r in records:
        discarded.update(r.discarded())
    manifest = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "config": cfg.to_dict(),
        "code_version": versions.pop() if versions else None,
        "shard": None if shard is None else {"index": shard, "count": num_shards},
        "episodes": {"total": len(records), **{s: splits.get(s, 0) for s in SPLITS}},
        "discarded": {reason: discarded.get(reason, 0) for reason in DISCARD_REASONS},
        "files": {rel: sha256_file(out_dir / rel) for rel in files},
    }
    write_json_atomic(out_dir / MANIFEST, manifest)
    return manifest


def read_manifest(path: Path) -> dict[str, Any]:
    """The manifest of the dataset folder ``path`` (format checked).

    Raises:
        DatasetError: no manifest (generation missing or unfinished) or an unknown format.
    """
    file = Path(path) / MANIFEST
    if not file.exists():
        raise DatasetError(
            f"{file} not found: the dataset at {path} does not exist or its generation did not finish "
            "(run ReachDataModule.prepare_data() or lfd.visuomotor.data.generate_dataset() to generate/resume it)"
        )
    manifest = read_json(file)
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT_NAME:
        raise DatasetError(f"{file} is not an lfd reaching-dataset manifest")
    if manifest.get("format_version") != FORMAT_VERSION:
        raise DatasetError(
            f"{file}: format version {manifest.get('format_version')!r:.40}, this code reads {FORMAT_VERSION}; "
            "regenerate"
        )
    shard, files = manifest.get("shard"), manifest.get("files")
    if not isinstance(manifest.get("config"), dict):
        raise DatasetError(f"{file}: config expected an object, got {manifest.get('config')!r:.60}")
    if shard is not None and not (
        isinstance(shard, dict)
        and all(
            isinstance(shard.get(k), int) and not isinstance(shard.get(k), bool) for k in ("index", "count")
        )
        and 0 <= shard["index"] < shard["count"]
    ):
        raise DatasetError(
            f"{file}: shard expected null or {{index, count}}, 0 <= index < count, got {shard!r:.60}"
        )
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        raise DatasetError(f"{file}: files expected an object of file -> SHA-256, got {files!r:.60}")
    allowed = re.compile(rf"{EPISODE_DIR}/ep-\d{{5,}}\.npz|{re.escape(STATS)}")
    outside = [rel for rel in files if not allowed.fullmatch(rel)]
    if outside:
        raise DatasetError(
            f"{file}: files lists {outside[:3]!r:.120}, not episode files or {STATS} of this folder"
        )
    return manifest


def config_differences(on_disk: dict[str, Any], wanted: dict[str, Any]) -> list[str]:
    """Human-readable ``key: on disk X, requested Y`` lines for differing config keys."""
    keys = sorted(set(on_disk) | set(wanted))
    return [
        f"{k}: on disk {on_disk.get(k)!r}, requested {wanted.get(k)!r}"
        for k in keys
        if on_disk.get(k) != wanted.get(k)
    ]


def verify_dataset(
    path: str | Path,
    cfg: GeneratorConfig | None = None,
    *,
    shard: int | Literal["any"] | None = None,
    num_shards: int = 1,
) -> dict[str, Any]:
    """Check a finished dataset folder against its manifest; returns the manifest.

    Checks: the manifest exists and has this format version; its config equals ``cfg``
    (if given); it is the full dataset (``shard=None``), the given shard of
    ``num_shards``, or any shard (``shard="any"``); every listed file exists with the
    recorded SHA-256; ``episodes/`` holds no unlisted file.

    Raises:
        DatasetError: naming the problem and the file.
    """
    path = Path(path)
    manifest = read_manifest(path)
    if cfg is not None:
        diff = config_differences(manifest["config"], cfg.to_dict())
        if diff:
            raise DatasetError(
                f"stale dataset {path}: its config differs from the requested one ({'; '.join(diff)}); "
                "use another dataset name or delete the folder to regenerate"
            )
    on_disk = manifest["shard"]
    if shard is None and on_disk is not None:
        raise DatasetError(
            f"{path} is shard {on_disk['index']} of {on_disk['count']}; join the shards with merge_shards() first"
        )
    if shard == "any" and on_disk is None:
        raise DatasetError(f"{path} is a full dataset, not a shard")
    if isinstance(shard, int) and on_disk != {"index": shard, "count": num_shards}:
        raise DatasetError(
            f"{path}: manifest describes shard {on_disk}, expected shard {shard} of {num_shards}"
        )
    for rel, digest in manifest["files"].items():
        file = path / rel
        if not file.is_file():
            raise DatasetError(f"corrupt dataset {path}: missing file {file}")
        if sha256_file(file) != digest:
            raise DatasetError(
                f"corrupt dataset {path}: checksum mismatch for {file} (file changed or damaged)"
            )
    listed = set(manifest["files"])
    extra = sorted(
        f.relative_to(path).as_posix()
        for f in (path / EPISODE_DIR).glob("*.npz")
        if f.relative_to(path).as_posix() not in listed
    )
    if extra:
        raise DatasetError(
            f"corrupt dataset {path}: unlisted episode files {extra[:5]}{' ...' if len(extra) > 5 else ''}"
        )
    return manifest
