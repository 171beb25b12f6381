"""Dataset exports and the LeRobot reader under careless and hostile input.

* ``overwrite=true`` replaces only an lfd export of the same kind: an unrelated folder, the
  source dataset, a folder holding it, the current folder, a symbolic link and an export of
  the other format are refused, and every byte of them stays.
* An interrupted export (an exception inside the writer) leaves the previous output as it
  was and no partial folder; leftovers of a killed run do not block the rerun.
* The LeRobot reader refuses ``data_path`` / ``video_path`` templates and files that lead
  outside the dataset folder, and names the file of a corrupt ``info.json`` or parquet.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from lfd.interop import LeRobotFolder, export_lerobot, export_robomimic, read_info
from lfd.interop.robomimic import export_kind
from lfd.io.files import EXPORT_MARKER, OutputRefused, export_marker, sha256_file

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "fixtures" / "lerobot_v3_reference"
#: Generator settings of a 3-episode dataset (32 px, 20 steps): generated in about a second.
DATA = dict(
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
#: A process id above Linux's largest (2**22): no process has it.
DEAD_PID = 4_194_305


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    """The source dataset ``<tmp>/data/tiny`` (3 episodes)."""
    from lfd.visuomotor.data import ReachDataModule

    root = tmp_path_factory.mktemp("security_interop") / "data"
    ReachDataModule(name="tiny", root=root, progress=False, num_gen_workers=1, **DATA).prepare_data()
    return root / "tiny"


def _overrides(source: Path, *extra: str) -> list[str]:
    data = [f"data.{k}={v}" for k, v in DATA.items() if k != "seed"]
    return [
        f"seed={DATA['seed']}",
        f"paths.data_dir={source.parent}",
        "data.name=tiny",
        "data.num_gen_workers=1",
        "progress=false",
        *data,
        *extra,
    ]


def _snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (hidden ones too) -> its SHA-256."""
    return {str(p.relative_to(folder)): sha256_file(p) for p in sorted(folder.rglob("*")) if p.is_file()}


def _victim(folder: Path) -> dict[str, str]:
    """An unrelated folder with a few files of the user's; returns its snapshot."""
    (folder / "sub").mkdir(parents=True)
    (folder / "thesis.tex").write_text("\\chapter{Results}\n")
    (folder / "sub" / "photo.jpg").write_bytes(os.urandom(256))
    return _snapshot(folder)


def test_robomimic_overwrite_of_an_unrelated_folder_is_refused_by_the_entry_point(source, tmp_path):
    victim = tmp_path / "my_documents"
    before = _victim(victim)
    cmd = [
        sys.executable,
        str(ROOT / "scripts" / "export_dataset.py"),
        *_overrides(
            source, "format=robomimic", f"out={victim}", "overwrite=true", f"hydra.run.dir={tmp_path}/run"
        ),
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert res.returncode == 2, res.stderr[-2000:]
    assert "Traceback" not in res.stderr
    lines = [line for line in res.stderr.splitlines() if line.startswith("export_dataset:")]
    assert (
        len(lines) == 1 and "refusing to overwrite" in lines[0] and "not an lfd robomimic export" in lines[0]
    )
    assert _snapshot(victim) == before  # every file still there, unchanged
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my_documents", "run"]  # no temporary left


def test_lerobot_overwrite_of_the_source_or_a_folder_holding_it_is_refused(source, compose):
    spec = importlib.util.spec_from_file_location("export_dataset", ROOT / "scripts" / "export_dataset.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    before = _snapshot(source.parent)
    cfg = compose("export_dataset", *_overrides(source, "format=lerobot", f"out={source}", "overwrite=true"))
    with pytest.raises(OutputRefused, match="it is or holds the source"):
        script.export(cfg)
    # even a planted lerobot marker does not make the dataset or its parent replaceable
    for folder in (source, source.parent):
        (folder / EXPORT_MARKER).write_text(json.dumps(export_marker("lerobot")))
        try:
            with pytest.raises(OutputRefused, match="it is or holds the source"):
                export_lerobot(source, folder, overwrite=True, progress=False)
        finally:
            (folder / EXPORT_MARKER).unlink()
    with pytest.raises(OutputRefused, match="it is or holds the source"):
        export_robomimic(source, source, overwrite=True, progress=False)
    with pytest.raises(FileExistsError, match="overwrite=True"):  # without overwrite, as before
        export_lerobot(source, source, progress=False)
    assert _snapshot(source.parent) == before


def test_overwrite_refuses_the_current_folder_links_and_the_other_format(source, tmp_path, monkeypatch):
    marked = tmp_path / "old.lerobot"
    marked.mkdir()
    (marked / EXPORT_MARKER).write_text(json.dumps(export_marker("lerobot")))
    (marked / "keep.txt").write_text("mine")
    link = tmp_path / "link.lerobot"
    link.symlink_to(marked)
    with pytest.raises(OutputRefused, match="symbolic link"):
        export_lerobot(source, link, overwrite=True, progress=False)
    with pytest.raises(OutputRefused, match=r"not an lfd robomimic export \(not a file\)"):
        export_robomimic(source, marked, overwrite=True, progress=False)
    h5 = tmp_path / "foreign.hdf5"
    with h5py.File(h5, "w") as f:
        f.create_dataset("data/x", data=[1, 2, 3])
    h5_sha = sha256_file(h5)
    with pytest.raises(OutputRefused, match="no lfd marker in the file"):
        export_robomimic(source, h5, overwrite=True, progress=False)
    with pytest.raises(OutputRefused, match="a file, not a folder"):
        export_lerobot(source, h5, overwrite=True, progress=False)
    (marked / EXPORT_MARKER).write_text(json.dumps(export_marker("robomimic")))
    with pytest.raises(OutputRefused, match="its marker says 'robomimic'"):
        export_lerobot(source, marked, overwrite=True, progress=False)
    (marked / EXPORT_MARKER).write_text(json.dumps(export_marker("lerobot")))
    monkeypatch.chdir(marked)
    with pytest.raises(OutputRefused, match="the current folder"):
        export_lerobot(source, ".", overwrite=True, progress=False)
    assert (marked / "keep.txt").read_text() == "mine" and link.is_symlink() and sha256_file(h5) == h5_sha
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign.hdf5", "link.lerobot", "old.lerobot"]


def _fail(*args, **kwargs):
    raise RuntimeError("power cut")


def test_interrupted_lerobot_export_keeps_the_previous_output_and_the_rerun_works(
    source, tmp_path, monkeypatch
):
    from lfd.interop.lerobot.writer import LeRobotWriter

    out, fresh = tmp_path / "ds.lerobot", tmp_path / "fresh.lerobot"
    export_lerobot(source, out, codec="h264", limit=1, progress=False)
    assert json.loads((out / EXPORT_MARKER).read_text())["kind"] == "lerobot"
    before = _snapshot(out)
    with monkeypatch.context() as m:
        m.setattr(LeRobotWriter, "finalize", _fail)
        for target, overwrite in ((out, True), (fresh, False)):
            with pytest.raises(RuntimeError, match="power cut"):
                export_lerobot(source, target, codec="h264", overwrite=overwrite, progress=False)
    assert _snapshot(out) == before  # the previous export, byte for byte
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds.lerobot"]  # no partial folder
    # what a killed run leaves: our marked temporary sibling (removed by the rerun) and a
    # look-alike without our marker (kept: not recognisably ours)
    leftover = tmp_path / f".ds.lerobot.lfd-partial-{DEAD_PID}-x1"
    (leftover / "ds.lerobot" / "data").mkdir(parents=True)
    (leftover / EXPORT_MARKER).write_text(json.dumps({**export_marker("lerobot"), "partial": True}))
    lookalike = tmp_path / f".ds.lerobot.lfd-partial-{DEAD_PID}-x2"
    lookalike.mkdir()
    (lookalike / "notes.txt").write_text("not lfd's")
    export_lerobot(source, out, codec="h264", overwrite=True, progress=False)
    export_lerobot(source, fresh, codec="h264", limit=2, progress=False)
    assert read_info(out)["total_episodes"] == 3 and read_info(fresh)["total_episodes"] == 2
    assert not leftover.exists() and (lookalike / "notes.txt").read_text() == "not lfd's"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["ds.lerobot", "fresh.lerobot", lookalike.name]
    )


def test_interrupted_robomimic_overwrite_keeps_the_old_file(source, tmp_path, monkeypatch):
    out = tmp_path / "ds.hdf5"
    export_robomimic(source, out, limit=1, progress=False)
    assert export_kind(out) == "robomimic"
    before = sha256_file(out)
    with monkeypatch.context() as m:
        m.setattr("lfd.interop.robomimic._obs", _fail)
        with pytest.raises(RuntimeError, match="power cut"):
            export_robomimic(source, out, overwrite=True, progress=False)
    assert sha256_file(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds.hdf5"]
    export_robomimic(source, out, overwrite=True, progress=False)
    with h5py.File(out, "r") as f:
        assert len(f["data"]) == 3


@pytest.fixture()
def reference(tmp_path) -> Path:
    dst = tmp_path / "ds"
    shutil.copytree(REFERENCE, dst)
    for p in dst.rglob("*"):
        p.chmod(0o755 if p.is_dir() else 0o644)
    return dst


def _set_info(root: Path, **changes) -> None:
    path = root / "meta" / "info.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), **changes}))


@pytest.mark.parametrize(
    ("field", "template"),
    [
        ("data_path", "../outside/data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"),
        ("data_path", "{ABS}/data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"),
        ("data_path", "data/{chunk_index.__class__}/file-{file_index:03d}.parquet"),
        ("video_path", "videos/../../outside/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"),
    ],
)
def test_lerobot_reader_refuses_templates_leading_outside(reference, field, template):
    outside = reference.parent / "outside"
    shutil.copytree(reference, outside)
    _set_info(reference, **{field: template.replace("{ABS}", str(outside))})
    with pytest.raises(ValueError, match=f"info.json {field}: ") as e:
        LeRobotFolder(reference)
    assert "\n" not in str(e.value)


def test_lerobot_reader_refuses_files_reached_through_symbolic_links(reference):
    outside = reference.parent / "outside"
    shutil.move(reference / "data", outside)
    (reference / "data").symlink_to(outside)  # data/chunk-000/... now resolves outside
    with pytest.raises(ValueError, match="data_path 'data/chunk-000/file-000.parquet' leads outside"):
        LeRobotFolder(reference)
    shutil.move(reference / "meta" / "tasks.parquet", outside / "tasks.parquet")
    (reference / "meta" / "tasks.parquet").symlink_to(outside / "tasks.parquet")
    (reference / "data").unlink()
    (reference / "data").mkdir()
    shutil.move(outside / "chunk-000", reference / "data" / "chunk-000")
    with pytest.raises(ValueError, match="'meta/tasks.parquet' leads outside"):
        LeRobotFolder(reference)


def test_lerobot_reader_names_a_corrupt_file(reference):
    data = reference / "data" / "chunk-000" / "file-000.parquet"
    data.write_bytes(data.read_bytes()[:100])
    with pytest.raises(ValueError, match=f"{data}: corrupt parquet file") as e:
        LeRobotFolder(reference)
    assert "\n" not in str(e.value)
    info = reference / "meta" / "info.json"
    info.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(ValueError, match=f"{info}: corrupt JSON"):
        read_info(reference)
    info.write_text("[1, 2]")
    with pytest.raises(ValueError, match=f"{info}: expected a JSON object"):
        read_info(reference)


def test_the_entry_point_refuses_the_output_before_generating_any_data(compose, tmp_path):
    """A refused output costs nothing: the missing dataset is not generated first."""
    spec = importlib.util.spec_from_file_location("export_dataset", ROOT / "scripts" / "export_dataset.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    victim = tmp_path / "my_documents"
    before = _victim(victim)
    missing = tmp_path / "data" / "tiny"
    cfg = compose("export_dataset", *_overrides(missing, "format=lerobot", f"out={victim}", "overwrite=true"))
    with pytest.raises(OutputRefused, match="not an lfd lerobot export"):
        script.export(cfg)
    assert not missing.exists() and _snapshot(victim) == before
