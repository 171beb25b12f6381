"""Meta-World demonstration datasets: the scripted experts' episodes with camera images, robot
states, actions and the DMP fitted to each, generated once per task and verified on every load.

Layout of ``<root>/<name>/``::

    episodes/train-00000.npz ...   one file per kept episode (frames, states, actions, solved,
    episodes/val-00000.npz ...     placement, reset_seed, dmp_*; written atomically)
    stats.json                     normalisation statistics of the train split
    manifest.json                  written last: config, counts, dropped episodes, SHA-256 per file

Episode ``i`` of a split is the first of up to ``max_attempts`` placements
(:func:`lfd.metaworld.placement_seed`, attempt 0, 1, ...) on which the expert succeeds within
``n_steps`` steps; failed attempts are dropped and counted in the manifest. Episodes depend on
the config, the seed, the split and ``i`` only, so generation resumes where it stopped (finished
episode files of the same config are kept) and a dataset with more episodes starts with the same
ones. The test split is not stored: the evaluator draws its placements from the test stream.

The DMP of an episode is :class:`lfd.dmp.DMP` (``n_basis`` per dimension) fitted to its state
trajectory ``(n_steps, 4)`` over ``duration = (n_steps - 1) * control_dt`` seconds.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lfd.checks import check_choice, check_int
from lfd.io.files import (
    DatasetError,
    json_bytes,
    read_json,
    sha256_file,
    write_bytes_atomic,
    write_npz_atomic,
)

__all__ = [
    "MetaWorldData",
    "MetaWorldDataConfig",
    "MetaWorldEpisode",
    "generate_demonstrations",
    "load_demonstrations",
]

FORMAT_NAME = "lfd-metaworld-demonstrations"
FORMAT_VERSION = 1
MANIFEST, STATS, EPISODE_DIR = "manifest.json", "stats.json", "episodes"
#: The stored splits (the test split's placements are drawn by the evaluator).
STORED_SPLITS = ("train", "val")
#: Smallest standard deviation written (a constant quantity gets this std).
STD_FLOOR = 1e-6


@dataclass(frozen=True)
class MetaWorldDataConfig:
    """What a Meta-World demonstration dataset holds (its content; checked when built).

    Args:
        task: Meta-World task name (:func:`lfd.metaworld.task_names`).
        seed: placement streams' seed.
        n_train, n_val: kept expert episodes in the train and validation splits.
        image_size: side (px) of the square camera images; camera: the fixed camera.
        camera_fovy: its vertical field of view, degrees (None: the scene's; a narrower one
            zooms in on the middle of the view).
        n_steps: control steps per demonstration (0.0125 s each).
        n_basis: DMP basis functions per state dimension.
        max_attempts: placements tried per episode before generation fails.

    The policies read ``image_size``, ``depth`` (False), ``duration``, ``n_steps`` and ``robot``
    (None: the state is the tool's) from it, as from a reaching dataset's config.
    """

    task: str
    seed: int = 0
    n_train: int = 50
    n_val: int = 10
    image_size: int = 96
    camera: str = "corner"
    camera_fovy: float | None = None
    n_steps: int = 150
    n_basis: int = 20
    max_attempts: int = 5

    depth = False
    robot = None
    n_joints = 4

    def __post_init__(self) -> None:
        from lfd.metaworld.env import CAMERAS, check_task

        check_task(self.task)
        check_int(self.seed, "data.seed", minimum=0)
        check_int(self.n_train, "data.n_train", minimum=1)
        check_int(self.n_val, "data.n_val", minimum=1)
        _int_in(self.image_size, "data.image_size", 16, 1024)
        check_choice(self.camera, "data.camera", CAMERAS)
        if self.camera_fovy is not None:
            if isinstance(self.camera_fovy, bool) or not isinstance(self.camera_fovy, (int, float)):
                raise ValueError(
                    f"data.camera_fovy must be degrees in 5..120 or null, got {self.camera_fovy!r}"
                )
            if not 5.0 <= float(self.camera_fovy) <= 120.0:
                raise ValueError(
                    f"data.camera_fovy must be degrees in 5..120 or null, got {self.camera_fovy!r}"
                )
            object.__setattr__(self, "camera_fovy", float(self.camera_fovy))
        _int_in(self.n_steps, "data.n_steps", 10, 500)
        _int_in(self.n_basis, "data.n_basis", 1, 200)
        _int_in(self.max_attempts, "data.max_attempts", 1, 100)

    @property
    def control_dt(self) -> float:
        from lfd.metaworld.env import CONTROL_DT

        return CONTROL_DT

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample of a demonstration."""
        return (self.n_steps - 1) * self.control_dt

    def count(self, split: str) -> int:
        return {"train": self.n_train, "val": self.n_val}[split]

    def to_dict(self) -> dict[str, Any]:
        """The settings; ``camera_fovy`` only when set (datasets made before it existed stay valid)."""
        out = dataclasses.asdict(self)
        if out["camera_fovy"] is None:
            del out["camera_fovy"]
        return out

    def content_sha256(self) -> str:
        """Hash of everything that defines an episode's bytes (not the episode counts)."""
        content = {k: v for k, v in self.to_dict().items() if k not in ("n_train", "n_val")}
        return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


@dataclass(frozen=True)
class MetaWorldEpisode:
    """One stored episode: ``split``, its ``index`` in the split and its arrays (module docstring)."""

    split: str
    index: int
    arrays: dict[str, np.ndarray]

    @property
    def frames(self) -> np.ndarray:
        return self.arrays["frames"]

    @property
    def states(self) -> np.ndarray:
        return self.arrays["states"]


@dataclass
class MetaWorldData:
    """A verified dataset in memory: ``config``, ``manifest``, train-split ``stats`` and episodes."""

    path: Path
    config: MetaWorldDataConfig
    manifest: dict[str, Any]
    stats: dict[str, dict[str, np.ndarray]]
    episodes: dict[str, list[MetaWorldEpisode]]

    def split(self, name: str) -> list[MetaWorldEpisode]:
        if name not in self.episodes:
            raise ValueError(f"split: expected one of {STORED_SPLITS}, got {name!r}")
        return self.episodes[name]

    def with_train_episodes(self, n: int) -> MetaWorldData:
        """A copy whose train split keeps its first ``n`` episodes, the statistics recomputed on
        them (validation unchanged): data-efficiency runs on one dataset."""
        train = self.episodes["train"][:n]
        stats = _stat_arrays(compute_stats([e.arrays for e in train]))
        return dataclasses.replace(self, episodes={**self.episodes, "train": train}, stats=stats)

    def fingerprint(self) -> dict[str, Any]:
        """What a checkpoint records of its training data: manifest hash, task, seed and every
        training placement."""
        return {
            "manifest_sha256": sha256_file(self.path / MANIFEST),
            "config_sha256": self.config.content_sha256(),
            "task": self.config.task,
            "seed": self.config.seed,
            "train_placements": [e.arrays["placement"].tolist() for e in self.split("train")],
        }


def _int_in(value, name: str, low: int, high: int) -> None:
    check_int(value, name, minimum=low)
    if value > high:
        raise ValueError(f"{name} must be an integer in {low}..{high}, got {value!r}")


def episode_file(split: str, index: int) -> str:
    return f"{EPISODE_DIR}/{split}-{index:05d}.npz"


def _code_version() -> str:
    import lfd

    root = Path(lfd.__file__).parent
    h = hashlib.sha256()
    for src in [*sorted((root / "metaworld").glob("*.py")), Path(__file__)]:
        h.update(src.name.encode() + b"\0" + src.read_bytes())
    return f"{lfd.__version__}+{h.hexdigest()[:16]}"


def _fit_dmp(states: np.ndarray, cfg: MetaWorldDataConfig) -> dict[str, np.ndarray]:
    from lfd.dmp import DMP

    t = np.arange(cfg.n_steps) * cfg.control_dt
    dmp = DMP(n_basis=cfg.n_basis).fit(t, states)
    return {
        "dmp_y0": np.asarray(dmp.y0_, dtype=np.float64),
        "dmp_goal": np.asarray(dmp.goal_, dtype=np.float64),
        "dmp_weights": np.asarray(dmp.weights_, dtype=np.float64),
        "dmp_tau": np.float64(dmp.tau_),
        "t": t,
    }


def _read_episode(path: Path, cfg_sha: str) -> dict[str, np.ndarray] | None:
    """The arrays of a finished episode file of this config, or None (absent or another config)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError) as e:
        raise DatasetError(f"{path}: unreadable episode file ({e}); delete it to regenerate") from None
    return arrays if str(arrays.get("config_sha256")) == cfg_sha else None


def _ours(name: str) -> bool:
    """A file or folder an unfinished generation leaves (episodes, statistics, atomic-write temporaries)."""
    return name in (EPISODE_DIR, STATS) or (name.startswith(f".{STATS}.") and name.endswith(".tmp"))


def generate_demonstrations(cfg: MetaWorldDataConfig, out_dir: str | Path, progress: bool = True) -> dict:
    """Generate (or resume, or verify) the dataset of ``cfg`` in ``out_dir``; returns its manifest.

    Raises:
        DatasetError: ``out_dir`` holds another dataset (different config or format), or the
            expert failed ``max_attempts`` placements in a row for one episode.
    """
    out_dir = Path(out_dir)
    if (out_dir / MANIFEST).is_file():
        return verify_demonstrations(out_dir, cfg)
    if out_dir.exists() and any(not _ours(p.name) for p in out_dir.iterdir()):
        raise DatasetError(
            f"{out_dir}: exists and is not an unfinished Meta-World dataset; choose another data.name"
        )
    from tqdm.auto import tqdm

    from lfd.metaworld.env import MetaWorldTask, placement_seed
    from lfd.metaworld.expert import record_expert

    (out_dir / EPISODE_DIR).mkdir(parents=True, exist_ok=True)
    cfg_sha, version = cfg.content_sha256(), _code_version()
    dropped = {s: 0 for s in STORED_SPLITS}
    todo = [(s, i) for s in STORED_SPLITS for i in range(cfg.count(s))]
    with (
        MetaWorldTask(cfg.task, image_size=cfg.image_size, camera=cfg.camera, fovy=cfg.camera_fovy) as task,
        tqdm(todo, desc=f"{cfg.task} demonstrations", disable=not progress, unit="ep") as bar,
    ):
        for split, i in bar:
            path = out_dir / episode_file(split, i)
            done = _read_episode(path, cfg_sha)
            if done is not None:
                dropped[split] += int(done["attempt"])
                continue
            for attempt in range(cfg.max_attempts):
                seed = placement_seed(cfg.seed, split, i, attempt)
                episode = record_expert(task, seed, cfg.n_steps)
                if episode.success:
                    break
                dropped[split] += 1
            else:
                raise DatasetError(
                    f"{cfg.task}: the expert failed {cfg.max_attempts} placements in a row ({split} episode {i}); "
                    f"raise data.max_attempts or data.n_steps"
                )
            arrays = {
                "frames": episode.frames,
                "states": episode.states,
                "actions": episode.actions,
                "solved": episode.solved,
                "placement": episode.placement,
                "reset_seed": np.int64(seed),
                "attempt": np.int64(attempt),
                "config_sha256": np.str_(cfg_sha),
                "code_version": np.str_(version),
                **_fit_dmp(episode.states, cfg),
            }
            write_npz_atomic(path, arrays)
    files = [episode_file(s, i) for s in STORED_SPLITS for i in range(cfg.count(s))]
    stats = compute_stats(
        [_read_episode(out_dir / f, cfg_sha) for f in files if f.startswith("episodes/train")]
    )
    write_bytes_atomic(out_dir / STATS, json_bytes(stats))
    manifest = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "config": cfg.to_dict(),
        "config_sha256": cfg_sha,
        "code_version": version,
        "episodes": {s: cfg.count(s) for s in STORED_SPLITS},
        "dropped": dropped,
        "files": {f: sha256_file(out_dir / f) for f in [*files, STATS]},
    }
    write_bytes_atomic(out_dir / MANIFEST, json_bytes(manifest))
    return manifest


def compute_stats(train: list[dict[str, np.ndarray]]) -> dict[str, dict[str, list]]:
    """``{name: {"mean", "std", "count"}}`` over the train episodes: ``joints`` (every state,
    ``(4,)``), ``velocity`` (every step's state change per second, ``(4,)``), ``goal`` ``(4,)``
    and ``weights`` ``(4, K)`` (one per episode); std floored at :data:`STD_FLOOR`."""
    if not train:
        raise DatasetError("compute_stats: the train split is empty")
    from lfd.visuomotor.data.datasets import command_velocities

    values = {
        "joints": np.concatenate([e["states"] for e in train]),
        "velocity": np.concatenate([command_velocities(e["states"], e["t"]) for e in train]),
        "goal": np.stack([e["dmp_goal"] for e in train]),
        "weights": np.stack([e["dmp_weights"] for e in train]),
    }
    return {
        k: {"mean": v.mean(0).tolist(), "std": np.maximum(v.std(0), STD_FLOOR).tolist(), "count": int(len(v))}
        for k, v in values.items()
    }


def _content(config: dict[str, Any]) -> dict[str, Any]:
    """The settings that make a finished dataset what it is: all but ``max_attempts`` (it only
    decides when generation gives up; a finished dataset is the same under any value)."""
    return {k: v for k, v in config.items() if k != "max_attempts"}


def verify_demonstrations(path: str | Path, cfg: MetaWorldDataConfig | None = None) -> dict[str, Any]:
    """The manifest of the finished dataset at ``path`` after checking its format, config (when
    ``cfg`` is given; ``max_attempts`` may differ) and every file's SHA-256.

    Raises:
        DatasetError: missing, unfinished, another config, or a file changed (one line each).
    """
    path = Path(path)
    if not (path / MANIFEST).is_file():
        raise DatasetError(f"{path}: no {MANIFEST} (not generated, or unfinished)")
    manifest = read_json(path / MANIFEST)
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT_NAME:
        raise DatasetError(f"{path}: not a Meta-World demonstration dataset (format {FORMAT_NAME!r})")
    if manifest.get("format_version") != FORMAT_VERSION:
        raise DatasetError(
            f"{path}: format version {manifest.get('format_version')!r}, this lfd reads {FORMAT_VERSION}"
        )
    theirs = manifest.get("config") if isinstance(manifest.get("config"), dict) else {}
    if cfg is not None and _content(theirs) != _content(cfg.to_dict()):
        diff = sorted(k for k, v in _content(cfg.to_dict()).items() if theirs.get(k) != v)
        raise DatasetError(
            f"{path}: generated with other settings ({', '.join(f'{k}={theirs.get(k)!r}' for k in diff)}); "
            "choose another data.name or delete the folder"
        )
    files = manifest.get("files")
    if not isinstance(files, dict):
        raise DatasetError(f"{path}: {MANIFEST} has no file list")
    for rel, digest in files.items():
        f = path / rel
        if not f.is_file() or sha256_file(f) != digest:
            raise DatasetError(f"{path}: {rel} is missing or changed since generation")
    return manifest


def load_demonstrations(path: str | Path, cfg: MetaWorldDataConfig | None = None) -> MetaWorldData:
    """Verify (:func:`verify_demonstrations`) and load a dataset."""
    path = Path(path)
    manifest = verify_demonstrations(path, cfg)
    try:
        config = MetaWorldDataConfig(**manifest["config"])
    except (TypeError, ValueError) as e:
        raise DatasetError(f"{path}: bad config in {MANIFEST}: {e}") from None
    if manifest.get("code_version") != _code_version():
        warnings.warn(
            f"{path} was generated by lfd code version {manifest.get('code_version')}, this is {_code_version()}: "
            "images or states may differ from what this version renders (delete the folder to regenerate)",
            RuntimeWarning,
            stacklevel=2,
        )
    sha = config.content_sha256()
    episodes = {
        s: [
            MetaWorldEpisode(s, i, _read_episode(path / episode_file(s, i), sha))
            for i in range(config.count(s))
        ]
        for s in STORED_SPLITS
    }
    return MetaWorldData(path, config, manifest, _stat_arrays(read_json(path / STATS)), episodes)


def _stat_arrays(stats: dict) -> dict[str, dict[str, np.ndarray]]:
    """``{name: {"mean", "std"}}`` float32 arrays of :func:`compute_stats`' lists."""
    return {k: {m: np.asarray(v[m], np.float32) for m in ("mean", "std")} for k, v in stats.items()}
