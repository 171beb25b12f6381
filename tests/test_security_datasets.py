"""LeRobot folders and lfd's own datasets under hostile and careless input (second round).

* Every count or size a LeRobot ``meta/info.json`` declares is checked against lfd's caps and
  the parquet footers before anything is allocated (a 10**9-episode claim under a 1.5 GiB
  address-space limit ends in one line, not in ``MemoryError``).
* ``fps=0``, a feature that is not an object, a bad feature (video) name, an episode whose
  frame range is reversed or shared with another episode, NaN in ``observation.state`` or in
  the DMP columns: each refused with one line naming the file, the field and the episode.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from lfd.interop import LeRobotDataModule, LeRobotFolder
from lfd.interop.lerobot.io import LeRobotDatasetError
from lfd.interop.lerobot.reader import MAX_EPISODES, MAX_FRAMES

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "fixtures" / "lerobot_v3_reference"
EPISODES = Path("meta/episodes/chunk-000/file-000.parquet")
DATA = Path("data/chunk-000/file-000.parquet")


@pytest.fixture()
def reference(tmp_path) -> Path:
    """A writable copy of the lerobot-written reference dataset (3 episodes: 20, 25, 30 frames)."""
    dst = tmp_path / "ds"
    shutil.copytree(REFERENCE, dst)
    for p in dst.rglob("*"):
        p.chmod(0o755 if p.is_dir() else 0o644)
    return dst


def _info(root: Path, **changes) -> None:
    path = root / "meta" / "info.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), **changes}))


def _feature(root: Path, name: str, value) -> None:
    path = root / "meta" / "info.json"
    info = json.loads(path.read_text())
    info["features"][name] = value
    path.write_text(json.dumps(info))


def _column(root: Path, rel: Path, name: str, change) -> None:
    """Rewrite column ``name`` of parquet file ``root / rel`` as ``change(list of values)``."""
    table = pq.read_table(root / rel)
    values = change(table.column(name).to_pylist())
    i = table.column_names.index(name)
    table = table.set_column(i, table.schema.field(i), pa.array(values, type=table.schema.field(i).type))
    pq.write_table(table, root / rel)


def _refused(root: Path, *fragments: str, load=LeRobotFolder) -> str:
    with pytest.raises(LeRobotDatasetError) as e:
        load(root)
    message = str(e.value)
    assert "\n" not in message, message
    for fragment in fragments:
        assert fragment in message, message
    return message


BOUNDED = """
import resource, sys
limit = 1536 << 20  # 1.5 GiB of address space: 10**9 of anything does not fit
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from lfd.interop import LeRobotFolder
try:
    LeRobotFolder(sys.argv[1])
except ValueError as e:
    print("refused:", e)
"""


@pytest.mark.parametrize(
    "changes",
    [
        {"total_episodes": 10**9},
        {"total_episodes": 1e9},
        {"total_frames": 10**9},
        {"total_episodes": MAX_EPISODES + 1},
        {"total_frames": MAX_FRAMES + 1},
    ],
    ids=["episodes-1e9", "episodes-float", "frames-1e9", "episodes-cap", "frames-cap"],
)
def test_lerobot_declared_counts_are_capped_before_anything_is_allocated(reference, changes):
    _info(reference, **changes)
    (name,) = changes
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    res = subprocess.run(
        [sys.executable, "-c", BOUNDED, str(reference)], capture_output=True, text=True, timeout=120, env=env
    )
    assert res.returncode == 0, res.stderr[-1500:]
    lines = res.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith("refused: ") and f"info.json {name}: " in lines[0], lines


def test_lerobot_info_json_is_read_within_a_size_and_depth_bound(reference):
    from lfd.interop.lerobot.io import MAX_JSON_BYTES

    info = reference / "meta" / "info.json"
    text = info.read_text()
    info.write_text(text + " " * (MAX_JSON_BYTES + 1 - len(text.encode())))
    _refused(reference, f"{info}: {MAX_JSON_BYTES + 1} bytes, more than lfd reads")
    info.write_text("[" * 100_000 + "]" * 100_000)  # 200 kB, nested deeper than the parser's recursion limit
    _refused(reference, f"{info}: corrupt JSON")


@pytest.mark.parametrize(
    ("changes", "fragment"),
    [
        ({"total_episodes": 4}, "meta/episodes holds 3 rows, "),
        ({"total_frames": 76}, "data/ holds 75 rows, "),
    ],
)
def test_lerobot_declared_counts_must_match_the_files(reference, changes, fragment):
    _info(reference, **changes)
    _refused(reference, fragment, f"total_{next(iter(changes)).split('_')[1]} says")


@pytest.mark.parametrize(
    ("cap", "fragment"),
    [
        ("MAX_FRAME_VALUES", "data/ declares 1950 values"),
        ("MAX_EPISODE_VALUES", "meta/episodes declares 846 values"),
    ],
)
def test_lerobot_parquet_values_are_capped_by_their_footers_before_reading(
    reference, monkeypatch, cap, fragment
):
    """What reading a parquet file allocates is bounded by its footer's value count, checked before any
    table is read (here with the cap lowered to just below the reference's own counts)."""
    import lfd.interop.lerobot.reader as reader

    monkeypatch.setattr(reader, cap, {"MAX_FRAME_VALUES": 1949, "MAX_EPISODE_VALUES": 845}[cap])
    read = reader.read_table

    def no_table_before_the_check(path):
        if cap == "MAX_EPISODE_VALUES" or "/data/" in str(path):
            raise AssertionError(f"{path} read before its footer was checked")
        return read(path)

    monkeypatch.setattr(reader, "read_table", no_table_before_the_check)
    monkeypatch.setattr(
        reader, "read_parquet_columns", lambda paths: pytest.fail("data read before the check")
    )
    _refused(reference, fragment, f"more than lfd reads ({getattr(reader, cap)})")


@pytest.mark.parametrize("fps", [0, -10, "10", None, 1e300])
def test_lerobot_fps_must_be_a_positive_number(reference, fps):
    _info(reference, fps=fps)
    _refused(reference, "info.json fps: expected a number in (0, ")


@pytest.mark.parametrize(
    ("name", "value", "fragment"),
    [
        ("action", "float32", "features.action: expected an object"),
        ("action", {"dtype": "float32", "shape": [0]}, "features.action.shape: "),
        ("action", {"dtype": "float32", "shape": [10**9]}, "features.action.shape: "),
        ("action", {"dtype": 7, "shape": [7]}, "features.action.dtype: "),
        ("observation.images.front", {"dtype": "video", "shape": [64, 64]}, "observation.images.front.shape"),
        ("observation.images.../../x", {"dtype": "video", "shape": [64, 64, 3]}, "is not a feature name"),
        (
            "observation.images.side",
            {"dtype": "video", "shape": [64, 64, 3]},
            "videos/observation.images.side",
        ),
    ],
    ids=["not-a-dict", "zero-size", "huge", "dtype", "video-shape", "video-name", "video-without-columns"],
)
def test_lerobot_bad_features_are_refused_naming_them(reference, name, value, fragment):
    _feature(reference, name, value)
    _refused(reference, fragment)


def test_lerobot_reversed_and_shared_frame_ranges_are_refused_naming_the_episode(reference, tmp_path):
    _column(reference, EPISODES, "dataset_to_index", lambda v: [v[0], 10, v[2]])  # episode 1: 20..10
    _refused(reference, f"{EPISODES} episode 1: frames dataset_from_index 20 .. dataset_to_index 10")
    shutil.rmtree(reference)
    shutil.copytree(REFERENCE, reference)
    for p in reference.rglob("*"):
        p.chmod(0o755 if p.is_dir() else 0o644)
    # every episode points at episode 0's frames (lengths kept consistent)
    _column(reference, EPISODES, "dataset_from_index", lambda v: [0, 0, 0])
    _column(reference, EPISODES, "dataset_to_index", lambda v: [20, 20, 20])
    _column(reference, EPISODES, "length", lambda v: [20, 20, 20])
    _refused(reference, "episode 1: frames 0..20 overlap episode 0")


def test_lerobot_frames_of_another_episode_are_refused(reference):
    # episode 1 claims frames 20..45, but the frame table says they belong to episode 2
    _column(reference, DATA, "episode_index", lambda v: [2 if 20 <= i < 45 else e for i, e in enumerate(v)])
    _refused(reference, f"{DATA} episode 1: frame 20", "has episode_index 2")


def test_lerobot_nan_state_is_refused_naming_the_episode_and_frame(reference):
    def nan_at_frame_3_of_episode_2(rows):
        rows[45 + 3][0] = float("nan")
        return rows

    _column(reference, DATA, "observation.state", nan_at_frame_3_of_episode_2)
    _refused(reference, f"{DATA} episode 2: observation.state is not finite", "at frame 3 (index 48)")


#: Generator settings of a 3-episode lfd dataset (32 px, 20 steps): generated in about a second.
TINY = dict(
    seed=3,
    n_train_objects=1,
    n_train_placements=2,
    n_test_objects=1,
    n_test_placements=1,
    n_val_objects=0,
    n_val_object_placements=0,
    image_size=32,
    n_steps=20,
    n_basis=8,
)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    """The lfd dataset ``<tmp>/data/tiny`` (3 episodes)."""
    from lfd.visuomotor.data import ReachDataModule

    root = tmp_path_factory.mktemp("security_datasets") / "data"
    ReachDataModule(name="tiny", root=root, progress=False, num_gen_workers=1, **TINY).prepare_data()
    return root / "tiny"


@pytest.fixture(scope="module")
def lfd_lerobot(tiny) -> Path:
    """A LeRobot export of :func:`tiny` (with lfd's DMP columns)."""
    from lfd.interop import export_lerobot

    return export_lerobot(tiny, tiny.parent.parent / "tiny.lerobot", codec="h264", progress=False)


@pytest.mark.parametrize(
    ("column", "change"),
    [
        ("lfd/dmp_weights", lambda w: [[np.nan, *row[1:]] if i == 1 else row for i, row in enumerate(w)]),
        ("lfd/dmp_goal", lambda g: [[np.inf, *row[1:]] if i == 1 else row for i, row in enumerate(g)]),
        ("lfd/dmp_weights", lambda w: [row[:-1] if i == 1 else row for i, row in enumerate(w)]),
    ],
    ids=["nan-weights", "inf-goal", "short-weights"],
)
def test_lerobot_bad_dmp_columns_are_refused_naming_the_episode(lfd_lerobot, tmp_path, column, change):
    ds = tmp_path / "ds"
    shutil.copytree(lfd_lerobot, ds)
    _column(ds, EPISODES, column, change)
    dm = LeRobotDataModule(ds, mode="dmp", num_workers=0, batch_size=2)
    _refused(ds, f"{EPISODES} episode 1: {column}: ", load=lambda _: dm.setup("fit"))


# ----------------------------------------------------------------------------- exports


def _snapshot(folder: Path) -> dict[str, str]:
    from lfd.io.files import sha256_file

    return {str(p.relative_to(folder)): sha256_file(p) for p in sorted(folder.rglob("*")) if p.is_file()}


def _export_overrides(tiny: Path, *extra: str) -> list[str]:
    data = [f"data.{k}={v}" for k, v in TINY.items() if k != "seed"]
    return [
        f"seed={TINY['seed']}",
        f"paths.data_dir={tiny.parent}",
        "data.name=tiny",
        "data.num_gen_workers=1",
        "progress=false",
        *data,
        *extra,
    ]


def test_the_export_command_refuses_an_output_inside_the_source(tiny, tmp_path):
    from lfd.visuomotor.data import verify_dataset

    before = _snapshot(tiny)
    cmd = [
        sys.executable,
        str(ROOT / "scripts" / "export_dataset.py"),
        *_export_overrides(
            tiny, "format=robomimic", f"out={tiny}/episodes/x.npz", f"hydra.run.dir={tmp_path}/run"
        ),
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert res.returncode == 2, res.stderr[-2000:]
    assert "Traceback" not in res.stderr
    lines = [line for line in res.stderr.splitlines() if line.startswith("export_dataset:")]
    assert (
        len(lines) == 1 and f"refusing to write {tiny}/episodes/x.npz: it lies inside the source" in lines[0]
    )
    assert _snapshot(tiny) == before
    verify_dataset(tiny)  # still a valid dataset: no unlisted episode file


def test_exports_refuse_outputs_inside_the_source_through_any_path(tiny, tmp_path):
    from lfd.interop import export_lerobot, export_robomimic
    from lfd.io.files import OutputRefused

    before = _snapshot(tiny)
    link = tmp_path / "link"
    link.symlink_to(tiny)
    for out in (tiny / "new" / "x.lerobot", tiny / "episodes" / "x.lerobot", link / "x.lerobot"):
        with pytest.raises(OutputRefused, match="it lies inside the source"):
            export_lerobot(tiny, out, codec="h264", progress=False)
    for out in (tiny / "x.hdf5", link / "episodes" / "y.hdf5"):
        with pytest.raises(OutputRefused, match="it lies inside the source"):
            export_robomimic(tiny, out, progress=False, overwrite=True)
    assert _snapshot(tiny) == before and not (tiny / "new").exists()


@pytest.mark.parametrize("limit", [-1, 0, 1.5, True, "2"])
def test_a_limit_that_is_not_a_positive_integer_is_refused(tiny, tmp_path, limit):
    from lfd.interop import export_lerobot, export_robomimic

    for export, who in ((export_lerobot, "export_lerobot"), (export_robomimic, "export_robomimic")):
        with pytest.raises(ValueError, match=rf"^{who}: limit must be an integer >= 1 \(or None\), got "):
            export(tiny, tmp_path / "out", limit=limit, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_the_export_command_refuses_limit_minus_one_before_generating(compose, tmp_path):
    import importlib.util

    spec = importlib.util.spec_from_file_location("export_dataset", ROOT / "scripts" / "export_dataset.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    missing = tmp_path / "data" / "tiny"
    cfg = compose("export_dataset", *_export_overrides(missing, "format=lerobot", "limit=-1"))
    with pytest.raises(ValueError, match=r"^limit must be an integer >= 1 \(or None\), got -1$"):
        script.export(cfg)
    assert not missing.exists()


def _race(run, n: int = 2) -> list[BaseException | None]:
    """Run ``run()`` in ``n`` threads at once; each one's exception (or None)."""
    import threading

    results: list[BaseException | None] = [None] * n

    def worker(i: int) -> None:
        try:
            run()
        except BaseException as e:  # the test looks at each outcome
            results[i] = e

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    return results


@pytest.mark.parametrize("fmt", ["lerobot", "robomimic"])
def test_two_exports_racing_to_one_new_output_one_wins_the_other_gets_one_line(
    tiny, tmp_path, monkeypatch, fmt
):
    """Both exports are held until both have written their temporary output (a barrier in the
    writer), so that they publish at the same moment: exactly one succeeds."""
    import threading

    from lfd.interop import export_lerobot, export_robomimic
    from lfd.interop.lerobot.writer import LeRobotWriter
    from lfd.interop.robomimic import export_kind

    barrier = threading.Barrier(2, timeout=120)
    out = tmp_path / ("race.lerobot" if fmt == "lerobot" else "race.hdf5")
    if fmt == "lerobot":
        finalize = LeRobotWriter.finalize

        def held_finalize(self, *args, **kwargs):
            barrier.wait()
            return finalize(self, *args, **kwargs)

        monkeypatch.setattr(LeRobotWriter, "finalize", held_finalize)
        results = _race(lambda: export_lerobot(tiny, out, codec="h264", limit=1, progress=False))
    else:
        import lfd.interop.robomimic as robomimic

        obs, seen = robomimic._obs, threading.local()

        def held_obs(*args, **kwargs):
            if not getattr(seen, "waited", False):
                seen.waited = True
                barrier.wait()
            return obs(*args, **kwargs)

        monkeypatch.setattr(robomimic, "_obs", held_obs)
        results = _race(lambda: export_robomimic(tiny, out, limit=1, progress=False))
    errors = [e for e in results if e is not None]
    assert len(errors) == 1, results
    assert isinstance(errors[0], FileExistsError), repr(errors[0])
    message = str(errors[0])
    assert "\n" not in message and f"{out} was written by another process meanwhile" in message
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]  # no temporary left behind
    if fmt == "lerobot":
        assert LeRobotFolder(out).info["total_episodes"] == 1
    else:
        assert export_kind(out) == "robomimic"


# ----------------------------------------------------------------------------- entry points


def _command(script: str, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, str(ROOT / script), *args, f"hydra.run.dir={cwd}/run"]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, cwd=cwd)


def _one_line(res: subprocess.CompletedProcess, prefix: str) -> str:
    assert res.returncode == 2, res.stderr[-2000:]
    assert "Traceback" not in res.stderr, res.stderr[-2000:]
    lines = [line for line in res.stderr.splitlines() if line.startswith(f"{prefix}: ")]
    assert len(lines) == 1, res.stderr[-2000:]
    return lines[0]


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["data.image_size=-1"], "train: data.image_size: expected an int >= 8, got -1"),
        (["data.batch_size=0"], "train: data.batch_size: expected an int >= 1, got 0"),
        (["data=lerobot"], "train: data.root: no value given (set data.root=...)"),
        (
            ["data=lerobot", "data.root=missing.lerobot"],
            "train: LeRobot dataset folder missing.lerobot not found",
        ),
    ],
    ids=["image-size", "batch-size", "no-root", "missing-root"],
)
def test_train_names_a_bad_data_setting_in_one_line(tmp_path, args, expected):
    res = _command("train.py", *args, f"paths.data_dir={tmp_path}/data", "trainer=cpu", cwd=tmp_path)
    assert _one_line(res, "train") == expected
    assert not (tmp_path / "data").exists()  # nothing generated


def test_train_names_a_dataset_with_one_flipped_byte_in_one_line(tiny, tmp_path):
    data = tmp_path / "data"
    shutil.copytree(tiny, data / "tiny")
    episode = data / "tiny" / "episodes" / "ep-00001.npz"
    raw = bytearray(episode.read_bytes())
    raw[len(raw) // 2] ^= 0x01
    episode.write_bytes(bytes(raw))
    res = _command(
        "train.py",
        *[a for a in _export_overrides(data / "tiny") if a != "progress=false"],
        "data.progress=false",
        "trainer=cpu",
        "+trainer.fast_dev_run=true",
        cwd=tmp_path,
    )
    line = _one_line(res, "train")
    assert f"corrupt dataset {data / 'tiny'}: checksum mismatch for {episode}" in line, line


def test_train_names_a_broken_lerobot_folder_in_one_line(reference, tmp_path):
    _info(reference, total_episodes=10**9)
    res = _command("train.py", "data=lerobot", f"data.root={reference}", "trainer=cpu", cwd=tmp_path)
    line = _one_line(res, "train")
    assert line.startswith(
        f"train: {reference}/meta/info.json total_episodes: expected an integer in [0, "
    ), line


# ----------------------------------------------------------------------------- merge_shards


@pytest.fixture(scope="module")
def shards(tiny) -> list[Path]:
    """Shards 0 and 1 of 2 of :func:`tiny`'s dataset, beside it."""
    from lfd.visuomotor.data import ReachDataModule, dataset_dir

    for i in range(2):
        ReachDataModule(
            name="tiny", root=tiny.parent, progress=False, num_gen_workers=1, shard=i, num_shards=2, **TINY
        ).prepare_data()
    return [dataset_dir(tiny.parent, "tiny", i, 2) for i in range(2)]


def test_merge_shards_never_writes_into_an_existing_dataset(tiny, shards, tmp_path):
    from lfd.io.files import DatasetError
    from lfd.visuomotor.data import merge_shards, verify_dataset

    before = _snapshot(tiny)
    with pytest.raises(DatasetError, match=f"refusing to merge into {tiny}: it holds a complete dataset"):
        merge_shards(shards, tiny)
    partial = tmp_path / "partial"
    (partial / "episodes").mkdir(parents=True)
    (partial / "episodes" / "ep-00000.npz").write_bytes(b"an unfinished generation's episode")
    with pytest.raises(DatasetError, match="it exists and is not empty"):
        merge_shards(shards, partial)
    with pytest.raises(DatasetError, match="lies inside or holds the shard"):
        merge_shards(shards, shards[0] / "merged")
    assert _snapshot(tiny) == before
    verify_dataset(tiny)
    assert (partial / "episodes" / "ep-00000.npz").read_bytes() == b"an unfinished generation's episode"
    empty = tmp_path / "empty"
    empty.mkdir()
    merged = merge_shards(shards, empty)  # a new (or empty) folder: merged, byte-identical to the whole
    assert _snapshot(merged) == before


def test_the_merge_command_refuses_an_existing_complete_dataset_in_one_line(tiny, shards, tmp_path):
    before = _snapshot(tiny)
    overrides = [a for a in _export_overrides(tiny) if a != "progress=false"]
    res = _command("scripts/generate_data.py", *overrides, "+merge_shards=2", cwd=tmp_path)
    line = _one_line(res, "generate_data")
    assert line.startswith(
        f"generate_data: merge_shards: refusing to merge into {tiny}: it holds a complete"
    ), line
    assert "merged" not in res.stdout
    assert _snapshot(tiny) == before


def test_lerobot_datamodule_bounds_the_decoded_frames_before_decoding(reference, monkeypatch):
    """``mode="velocity"`` holds every frame in memory: 75 frames of 64 x 64 px are 921,600 bytes,
    refused under a cap lowered just below that, before any video is opened."""
    import lfd.interop.lerobot.datamodule as datamodule

    monkeypatch.setattr(datamodule, "MAX_IMAGE_BYTES", 75 * 64 * 64 * 3 - 1)
    monkeypatch.setattr(
        LeRobotFolder, "frames", lambda *a, **k: pytest.fail("a video decoded before the check")
    )
    dm = LeRobotDataModule(reference, mode="velocity")
    _refused(
        reference,
        "mode='velocity' holds 75 images of observation.images.front (64x64)",
        load=lambda _: dm.setup("fit"),
    )


# ----------------------------------------------------------------------------- lfd's own datasets


def _rewrite_episode(tiny: Path, tmp_path: Path, index: int, change) -> Path:
    """A copy of :func:`tiny` whose episode ``index`` is rewritten as ``change(arrays)`` and whose
    manifest lists the new checksum (a dataset forged consistently, not damaged by accident)."""
    from lfd.io.files import sha256_file, write_npz_atomic

    ds = tmp_path / "tiny"
    shutil.copytree(tiny, ds)
    episode = ds / "episodes" / f"ep-{index:05d}.npz"
    with np.load(episode, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    write_npz_atomic(episode, change(arrays))
    manifest = json.loads((ds / "manifest.json").read_text())
    manifest["files"][f"episodes/ep-{index:05d}.npz"] = sha256_file(episode)
    (ds / "manifest.json").write_text(json.dumps(manifest))
    return episode


def _nan_at(a: dict, key: str, flat: int) -> dict:
    value = a[key].copy()
    value.reshape(-1)[flat] = np.nan
    return {**a, key: value}


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (lambda a: _nan_at(a, "joints", 9), "joints is not finite"),
        (lambda a: {**a, "dmp_weights": a["dmp_weights"] * np.inf}, "dmp_weights is not finite"),
        (lambda a: {k: v for k, v in a.items() if k != "t"}, "no ['t']"),
        (lambda a: {**a, "index": np.array(0)}, "holds episode 0, not 1"),
    ],
    ids=["nan-joints", "inf-weights", "no-t", "another-episode"],
)
def test_lfd_dataset_with_consistent_checksums_but_bad_episodes_is_refused(tiny, tmp_path, change, fragment):
    from lfd.io.files import DatasetError
    from lfd.visuomotor.data import load_dataset

    episode = _rewrite_episode(tiny, tmp_path, 1, change)
    with pytest.raises(DatasetError) as e:
        load_dataset(tmp_path / "tiny")
    assert str(episode) in str(e.value) and fragment in str(e.value) and "\n" not in str(e.value), str(
        e.value
    )


def test_lfd_episode_whose_arrays_inflate_past_the_cap_is_refused_before_reading(tiny, tmp_path):
    """A 256 MiB + 8 byte array of zeros deflates to about 250 kB: the zip directory's declared size
    refuses it before numpy allocates anything."""
    import zipfile

    from lfd.io.files import DatasetError, sha256_file
    from lfd.visuomotor.data import load_dataset
    from lfd.visuomotor.data.episodes import MAX_EPISODE_ARRAY_BYTES

    n = MAX_EPISODE_ARRAY_BYTES // 8 + 1

    def bomb(arrays):
        return {k: v for k, v in arrays.items() if k != "velocities"}  # written below, streamed

    episode = _rewrite_episode(tiny, tmp_path, 1, bomb)
    with (
        zipfile.ZipFile(episode, "a", compression=zipfile.ZIP_DEFLATED) as zf,
        zf.open("velocities.npy", "w", force_zip64=True) as f,
    ):
        np.lib.format.write_array_header_2_0(f, {"descr": "<f8", "fortran_order": False, "shape": (n,)})
        chunk = bytes(1 << 20)
        for _ in range(n * 8 // len(chunk)):
            f.write(chunk)
        f.write(bytes(n * 8 % len(chunk)))
    assert episode.stat().st_size < 2 * 2**20
    manifest = json.loads((tmp_path / "tiny" / "manifest.json").read_text())
    manifest["files"]["episodes/ep-00001.npz"] = sha256_file(episode)
    (tmp_path / "tiny" / "manifest.json").write_text(json.dumps(manifest))
    cap = rf"more than lfd reads \({MAX_EPISODE_ARRAY_BYTES}\)"
    with pytest.raises(
        DatasetError, match=rf"corrupt episode file {episode}: its arrays declare \d+ bytes, {cap}"
    ):
        load_dataset(tmp_path / "tiny")


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (
            lambda m: {**m, "files": {**m["files"], "../../outside.txt": "0" * 64}},
            "files lists ['../../outside.txt']",
        ),
        (lambda m: {**m, "files": ["episodes/ep-00000.npz"]}, "files expected an object"),
        (lambda m: {**m, "shard": {"index": 3, "count": 2}}, "shard expected null or"),
        (lambda m: {k: v for k, v in m.items() if k != "config"}, "config expected an object"),
    ],
    ids=["outside", "files-list", "shard", "no-config"],
)
def test_lfd_manifest_is_checked_before_it_is_used(tiny, tmp_path, change, fragment):
    from lfd.io.files import DatasetError
    from lfd.visuomotor.data import load_dataset

    ds = tmp_path / "tiny"
    shutil.copytree(tiny, ds)
    manifest = ds / "manifest.json"
    manifest.write_text(json.dumps(change(json.loads(manifest.read_text()))))
    with pytest.raises(DatasetError) as e:
        load_dataset(ds)
    assert str(e.value).startswith(f"{manifest}: ") and fragment in str(e.value) and "\n" not in str(e.value)


def test_lerobot_task_table_that_does_not_decode_is_one_line(reference):
    """A task table with one flipped byte (its task string no longer UTF-8: found by the fuzz harness):
    one line naming meta/tasks.parquet, not a UnicodeDecodeError without the file."""
    path = reference / "meta" / "tasks.parquet"
    data = bytearray(path.read_bytes())
    data[122] ^= 128
    path.write_bytes(bytes(data))
    _refused(reference, str(path), "unreadable task table")
