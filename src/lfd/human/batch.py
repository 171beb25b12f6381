"""Arm analysis of one skeleton file or of every file in a folder, with a summary table.

The stages that ``scripts/analyze_arm.py`` chains, callable from the package::

    from lfd.human.batch import analyze_folder

    rows = analyze_folder("recordings/", "out/", analysis={"side": "left", "body_mass": 80.0})
    # out/<file>/arm.{csv,mot,json} and figures per file, out/summary.csv: one row per file

A file that cannot be read or analysed (``ValueError``, ``FileNotFoundError``: malformed content,
missing joints, a scale that is not a person's: an upper arm outside 0.15-0.6 m, a frame rate
outside 1-1000 Hz, frames in another length unit or single-frame spikes, see
:mod:`lfd.human.plausibility`; fewer than :data:`~lfd.human.analysis.MIN_FRAMES` frames; a file or
a ``.gz`` content over :data:`~lfd.human.readers.common.MAX_SKELETON_BYTES`) becomes a row with
``status = "error: <one-line message>"`` and the batch goes on; a pipe or device named like a
recording is skipped with a line; the others have ``status = "ok"`` (their outputs written, each
file into its own folder: :func:`output_names`) and their
:meth:`~lfd.human.ArmAnalysis.summary` (ranges of motion in degrees, peak torques in N m).
"""

from __future__ import annotations

import csv
import fnmatch
import io
import os
import sys
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from lfd.io.files import write_text_atomic

from .analysis import ArmAnalysis, analyze_arm
from .plausibility import check_body_mass
from .readers import iter_skeleton_files, read_skeleton
from .readers.common import check_units

__all__ = [
    "SUMMARY_FILE",
    "analyze_file",
    "analyze_folder",
    "output_names",
    "skeleton_files",
    "write_summary",
]

#: The batch summary's file name in the output folder.
SUMMARY_FILE = "summary.csv"
_SUFFIXES = (".gz", ".csv", ".skeleton", ".trc", ".txt")


def analyze_file(
    path: str | Path,
    out_dir: str | Path,
    *,
    format: str | None = None,
    units: str | None = None,
    reader: Mapping[str, Any] | None = None,
    analysis: Mapping[str, Any] | None = None,
    plots: bool = True,
    gif: bool = True,
    gif_frames: int = 150,
) -> ArmAnalysis:
    """Read ``path`` (:func:`lfd.human.read_skeleton` with ``format``, ``units`` (m, cm, mm;
    ``None``: the format's own) and ``reader`` options), analyse it (:func:`lfd.human.analyze_arm`
    with ``analysis`` options) and write every output into ``out_dir`` (:meth:`ArmAnalysis.save`).

    Raises what the reader and the analysis raise, before anything is written: ``ValueError``
    for an implausible scale (upper arm, frame rate, body mass) as for malformed content."""
    options = dict(reader or {})
    if units is not None:
        if options.get("units", units) != units:
            raise ValueError(f"units={units!r} and reader.units={options['units']!r} disagree; give one")
        options["units"] = units
    skeleton = read_skeleton(path, format=format, **options)
    result = analyze_arm(skeleton, **dict(analysis or {}))
    result.save(out_dir, plots=plots, gif=gif, gif_frames=gif_frames)
    return result


def skeleton_files(folder: str | Path, pattern: str | None = None) -> list[Path]:
    """The files of ``folder`` to analyse, sorted: those matching the glob ``pattern`` (relative to
    the folder), or every recognised skeleton file, recursively (``pattern=None``)."""
    folder = Path(folder)
    if pattern:
        return sorted(
            p
            for p in folder.rglob("*")
            if p.is_file() and fnmatch.fnmatch(str(p.relative_to(folder)), pattern)
        )
    return list(iter_skeleton_files(folder))


def analyze_folder(
    folder: str | Path,
    out_dir: str | Path,
    *,
    pattern: str | None = None,
    progress: bool = True,
    **options: Any,
) -> list[dict[str, Any]]:
    """:func:`analyze_file` for each of :func:`skeleton_files` into ``out_dir/<name>`` (one
    folder per file, :func:`output_names`), then :func:`write_summary` to ``out_dir/summary.csv``;
    returns the rows: ``file`` (relative path), ``output`` (its folder name, empty when nothing
    was written), ``status`` (``ok``: written; ``error: <line>``; ``skipped: not a regular file``
    for a pipe or device, with a line on stderr) and the summary values.

    ``options`` are :func:`analyze_file`'s keywords (``format``, ``units``, ``reader``, ``analysis``,
    ``plots``, ``gif``, ``gif_frames``).

    Raises:
        FileNotFoundError: ``folder`` holds no file to analyse. ValueError: an option wrong for
        every file (``units``, ``analysis["body_mass"]`` outside 20-250 kg), before any file is read.
    """
    folder, out = Path(folder), Path(out_dir)
    check_units(options.get("units"))
    check_units((options.get("reader") or {}).get("units"))
    if "body_mass" in (options.get("analysis") or {}):
        check_body_mass(options["analysis"]["body_mass"])
    files = skeleton_files(folder, pattern)
    if not files:
        raise FileNotFoundError(f"file={folder}: no skeleton files found (pattern={pattern})")
    rels = [path.relative_to(folder) for path in files]
    rows = []
    for path, rel, name in tqdm(
        list(zip(files, rels, output_names(rels))), desc="analyse", unit="file", disable=not progress
    ):
        if not path.is_file():  # a FIFO or device named like a recording would block the batch
            line = f"{path}: not a regular file (a pipe or device?); skipped"
            tqdm.write(f"[lfd] {line}", file=sys.stderr)
            rows.append({"file": str(rel), "output": "", "status": "skipped: not a regular file"})
            continue
        try:
            result = analyze_file(path, out / name, **options)
            row = {"file": str(rel), "output": name, "status": "ok"}
            row.update({k: v for k, v in result.summary().items() if k not in ("source", "gaps_left")})
            row["gaps_left"] = len(result.quality["gaps_left"])
        except (ValueError, FileNotFoundError) as exc:  # bad file: report it, keep going
            row = {"file": str(rel), "output": "", "status": "error: " + str(exc).replace("\n", " ")}
        rows.append(row)
    write_summary(rows, out / SUMMARY_FILE)
    return rows


def output_names(rels: Sequence[Path]) -> list[str]:
    """One output folder name per input file (paths relative to the batch folder), all different,
    also when compared without case (as on macOS and Windows), and never :data:`SUMMARY_FILE`.

    The name is the relative path with ``/`` as ``__`` and the recording suffixes dropped
    (``sub/rec.csv.gz`` -> ``sub__rec``); where that names two files (``rec.csv`` and
    ``rec.csv.gz``) they keep their suffixes, and a name still taken gets ``~2``, ``~3``, ...
    (``sub/x.csv`` and ``sub__x.csv``).
    """
    short = []
    for rel in rels:
        name = str(rel).replace(os.sep, "/").replace("/", "__")
        for suffix in _SUFFIXES:
            name = name.removesuffix(suffix)
        short.append(name)
    counts = Counter(n.lower() for n in short)
    taken = {SUMMARY_FILE.lower()}
    names = []
    for rel, name in zip(rels, short):
        if not name or counts[name.lower()] > 1:
            name = str(rel).replace(os.sep, "/").replace("/", "__")
        candidate, k = name, 2
        while candidate.lower() in taken:
            candidate, k = f"{name}~{k}", k + 1
        taken.add(candidate.lower())
        names.append(candidate)
    return names


def write_summary(rows: list[dict[str, Any]], path: str | Path) -> Path:
    """One CSV row per file (the union of the rows' keys as columns, floats to 4 significant
    digits), written atomically; returns the path."""
    keys = list(dict.fromkeys(k for row in rows for k in row))
    buffer = io.StringIO(newline="")
    writer = csv.DictWriter(buffer, fieldnames=keys)
    writer.writeheader()
    for row in rows:
        writer.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    return write_text_atomic(Path(path), buffer.getvalue())
