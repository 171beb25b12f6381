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

from lfd.io.files import write_text_atomic


def pyarrow_modules():
    """``(pyarrow, pyarrow.parquet)``.

    Raises:
        ImportError: pyarrow is not installed.
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:  # pragma: no cover - pyarrow is a declared dependency
        raise ImportError("lfd.interop needs pyarrow: pip install pyarrow") from e
    return pa, pq


def write_json(path: Path, obj: Any) -> None:
    """``obj`` as JSON with a 4-space indent and non-ASCII characters kept, as lerobot's
    ``write_json`` writes it (atomically: temp file + rename)."""
    write_text_atomic(path, json.dumps(obj, indent=4, ensure_ascii=False))


def read_json(path: Path) -> Any:
    """The parsed JSON file ``path``.

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the file is not valid JSON.
    """
    try:
        return json.loads(Path(path).read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: corrupt JSON ({e})") from e


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
    column, or in the pandas index ``__index_level_0__`` as lerobot writes them)."""
    _, pq = pyarrow_modules()
    t = pq.read_table(path).to_pydict()
    name_col = "task" if "task" in t else "__index_level_0__"
    return [s for _, s in sorted(zip(t["task_index"], t[name_col], strict=True))]


def read_parquet_columns(paths: Sequence[Path]) -> dict[str, np.ndarray]:
    """The parquet files ``paths`` concatenated, as column -> array: ``(N,)`` for scalar
    columns, ``(N, D)`` for (fixed-size) list columns."""
    pa, pq = pyarrow_modules()
    table = pa.concat_tables([pq.read_table(f) for f in paths])
    out = {}
    for key in table.column_names:
        col = table.column(key).combine_chunks()
        if pa.types.is_fixed_size_list(col.type) or pa.types.is_list(col.type):
            out[key] = np.asarray(col.flatten().to_numpy(zero_copy_only=False)).reshape(len(col), -1)
        else:
            out[key] = col.to_numpy(zero_copy_only=False)
    return out
