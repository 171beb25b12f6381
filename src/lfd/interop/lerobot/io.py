"""JSON and parquet files of a LeRobot v3.0 dataset, byte-compatible with lerobot's own.

pyarrow is imported on first use (:func:`pyarrow_modules`); JSON is written atomically
through :func:`lfd.io.files.write_text_atomic`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lfd.checks import one_line
from lfd.io.files import DatasetError, show, write_text_atomic

#: Largest ``meta/*.json`` file read (bytes): ``info.json`` and ``stats.json`` of real datasets
#: are a few hundred KiB at most.
MAX_JSON_BYTES = 16 * 1024 * 1024


class LeRobotDatasetError(DatasetError):
    """A LeRobot dataset that is corrupt, inconsistent or over lfd's limits (a :class:`ValueError`);
    the one-line message names the file, the field and, where there is one, the episode."""


class LeRobotFileMissing(LeRobotDatasetError, FileNotFoundError):
    """A LeRobot dataset folder or one of its files is missing (both a :class:`ValueError`, through
    :class:`~lfd.io.files.DatasetError`, and a :class:`FileNotFoundError`)."""


def pyarrow_modules():
    """``(pyarrow, pyarrow.parquet)``.

    Raises:
        ImportError: pyarrow is not installed.
    """
    try:
        import pyarrow as pa
        import pyarrow.compute  # pa.compute
        import pyarrow.parquet as pq
    except ImportError as e:  # pragma: no cover - pyarrow is a declared dependency
        raise ImportError("lfd.interop needs pyarrow: pip install pyarrow") from e
    return pa, pq


def hf_feature(feature: dict) -> dict:
    """The Hugging Face ``datasets`` feature of an ``info.json`` feature, as stored in the
    ``huggingface`` metadata of the data parquet: a ``Value`` for shape ``[1]``, else a
    fixed-length ``List`` of values."""
    value = {"dtype": feature["dtype"], "_type": "Value"}
    if feature["shape"] == [1]:
        return value
    return {"feature": value, "length": int(feature["shape"][0]), "_type": "List"}


def extra_column_type(value: Any):
    """The arrow type of an extra episode column holding ``value``: bool, int64, float64,
    string, or a list of int64 / float64 for a flat numeric sequence.

    Raises:
        ValueError: any other value.
    """
    pa, _ = pyarrow_modules()
    if isinstance(value, bool | np.bool_):
        return pa.bool_()
    if isinstance(value, int | np.integer):
        return pa.int64()
    if isinstance(value, float | np.floating):
        return pa.float64()
    if isinstance(value, str):
        return pa.string()
    arr = np.asarray(value)
    if arr.ndim == 1 and arr.dtype.kind in "fiu":
        return pa.list_(pa.int64() if arr.dtype.kind in "iu" else pa.float64())
    raise ValueError(
        f"LeRobotEpisode.extra: unsupported value {value!r} (str, number, bool or a flat numeric list)"
    )


def write_json(path: Path, obj: Any) -> None:
    """``obj`` as JSON with a 4-space indent and non-ASCII characters kept, as lerobot's
    ``write_json`` writes it (atomically: temp file + rename)."""
    write_text_atomic(path, json.dumps(obj, indent=4, ensure_ascii=False))


def read_json(path: Path) -> Any:
    """The parsed JSON file ``path`` (at most :data:`MAX_JSON_BYTES`).

    Raises:
        LeRobotFileMissing: no file at ``path``.
        LeRobotDatasetError: the file is larger than :data:`MAX_JSON_BYTES`, not valid UTF-8
            JSON, or nested too deep to parse.
    """
    path = Path(path)
    if not path.is_file():
        raise LeRobotFileMissing(f"{path} not found")
    size = path.stat().st_size
    if size > MAX_JSON_BYTES:
        raise LeRobotDatasetError(
            f"{path}: {size} bytes, more than lfd reads ({MAX_JSON_BYTES} bytes at most)"
        )
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise LeRobotDatasetError(f"{path}: corrupt JSON ({one_line(str(e))})") from None


def read_table(path: Path):
    """The parquet file ``path`` as a pyarrow table.

    Raises:
        LeRobotFileMissing: no file at ``path``.
        LeRobotDatasetError: ``path`` is not a readable parquet file (the message names it).
    """
    pa, pq = pyarrow_modules()
    if not Path(path).is_file():
        raise LeRobotFileMissing(f"{path} not found")
    try:
        return pq.read_table(path)
    except (pa.ArrowException, OSError, UnicodeDecodeError) as e:
        raise LeRobotDatasetError(f"{path}: corrupt parquet file ({one_line(e)})") from e


def parquet_footer(path: Path) -> tuple[int, int]:
    """``(rows, values)`` that the footer of parquet file ``path`` declares: its row count and
    the number of values of all its columns (list entries counted one by one), which bound
    what reading it allocates. Nothing but the footer is read.

    Raises:
        LeRobotFileMissing, LeRobotDatasetError: as :func:`read_table`.
    """
    pa, pq = pyarrow_modules()
    if not Path(path).is_file():
        raise LeRobotFileMissing(f"{path} not found")
    try:
        md = pq.read_metadata(path)
        values = sum(
            md.row_group(i).column(j).num_values
            for i in range(md.num_row_groups)
            for j in range(md.num_columns)
        )
        return int(md.num_rows), int(values)
    except (pa.ArrowException, OSError) as e:
        raise LeRobotDatasetError(f"{path}: corrupt parquet file ({one_line(str(e))})") from e


def write_tasks(path: Path, tasks: Sequence[str]) -> None:
    """``tasks.parquet`` with ``task_index = 0..len(tasks)-1``, laid out as
    ``pandas.DataFrame({"task_index": ...}, index=tasks).to_parquet()`` writes it (lerobot's
    layout): the task strings are the pandas index, column ``__index_level_0__``."""
    pa, pq = pyarrow_modules()
    pandas_meta = {
        "index_columns": ["__index_level_0__"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "str",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": None,
                "field_name": "__index_level_0__",
                "pandas_type": "object",
                "numpy_type": "str",
                "metadata": None,
            },
        ],
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "3.1.1",
    }
    schema = pa.schema(
        [pa.field("task_index", pa.int64()), pa.field("__index_level_0__", pa.large_string())],
        metadata={"pandas": json.dumps(pandas_meta)},
    )
    table = pa.table(
        {"task_index": np.arange(len(tasks), dtype=np.int64), "__index_level_0__": list(tasks)}, schema=schema
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path, compression="snappy")


def read_tasks(path: Path) -> list[str]:
    """Task strings of a ``tasks.parquet`` in ``task_index`` order (the strings in a ``task``
    column, or in the pandas index ``__index_level_0__`` as lerobot writes them).

    Raises:
        LeRobotDatasetError: not a readable parquet file, other columns, task strings that are not
            UTF-8 text, or task indices that are not distinct integers (the message names the file).
    """
    pa, _ = pyarrow_modules()
    try:
        t = read_table(path).to_pydict()
    except (pa.ArrowException, UnicodeDecodeError) as e:
        raise LeRobotDatasetError(f"{path}: unreadable task table ({one_line(e)})") from e
    if "task_index" not in t or not {"task", "__index_level_0__"} & set(t):
        raise LeRobotDatasetError(
            f"{path}: expected columns task_index and task (or __index_level_0__), got {show(sorted(t))}"
        )
    name_col = "task" if "task" in t else "__index_level_0__"
    index, names = t["task_index"], t[name_col]
    if not all(isinstance(i, int) and not isinstance(i, bool) for i in index) or len(set(index)) != len(
        index
    ):
        raise LeRobotDatasetError(f"{path}: task_index must hold distinct integers")
    if not all(isinstance(n, str) for n in names):
        raise LeRobotDatasetError(f"{path}: {name_col} must hold the task strings")
    return [s for _, s in sorted(zip(index, names, strict=True))]


def read_parquet_columns(paths: Sequence[Path]) -> dict[str, np.ndarray]:
    """The parquet files ``paths`` concatenated, as column -> array: ``(N,)`` for scalar
    columns, ``(N, D)`` for (fixed-size) list columns."""
    pa, _ = pyarrow_modules()
    tables = [read_table(f) for f in paths]
    try:
        table = pa.concat_tables(tables)
    except pa.ArrowException as e:
        raise LeRobotDatasetError(
            f"{', '.join(map(str, paths))}: parquet files with different columns ({one_line(str(e))})"
        ) from e
    out = {}
    for key in table.column_names:
        col = table.column(key).combine_chunks()
        if pa.types.is_fixed_size_list(col.type) or pa.types.is_list(col.type):
            flat = np.asarray(col.flatten().to_numpy(zero_copy_only=False))
            lengths = pa.compute.min_max(pa.compute.list_value_length(col))
            if len(col) and (col.null_count or lengths["min"] != lengths["max"]):
                raise LeRobotDatasetError(
                    f"{', '.join(map(str, paths))}: column {key} has rows of different lengths (or empty rows)"
                )
            out[key] = flat.reshape(len(col), -1)
        else:
            out[key] = col.to_numpy(zero_copy_only=False)
    return out
