"""JSON and parquet files as lerobot writes and reads them."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from lfd.interop.lerobot.io import (
    extra_column_type,
    hf_feature,
    read_json,
    read_parquet_columns,
    read_tasks,
    write_json,
    write_tasks,
)


def test_json_indent_and_unicode(tmp_path):
    path = tmp_path / "meta" / "info.json"
    path.parent.mkdir()
    write_json(path, {"task": "grüne Tasse", "n": [1, 2]})
    assert path.read_text(encoding="utf-8") == (
        '{\n    "task": "grüne Tasse",\n    "n": [\n        1,\n        2\n    ]\n}'
    )
    assert read_json(path) == {"task": "grüne Tasse", "n": [1, 2]}
    path.write_text("{not json")
    with pytest.raises(ValueError, match="corrupt JSON"):
        read_json(path)


def test_tasks_round_trip_through_the_pandas_index(tmp_path):
    path = tmp_path / "meta" / "tasks.parquet"
    write_tasks(path, ["reach the red box from above", "reach the blue cylinder from the side"])
    table = pq.read_table(path)
    assert table.column_names == ["task_index", "__index_level_0__"]
    assert json.loads(table.schema.metadata[b"pandas"])["index_columns"] == ["__index_level_0__"]
    assert read_tasks(path) == ["reach the red box from above", "reach the blue cylinder from the side"]
    # a "task" column (another writer's layout) is read too, in task_index order
    pq.write_table(pa.table({"task_index": [1, 0], "task": ["b", "a"]}), tmp_path / "other.parquet")
    assert read_tasks(tmp_path / "other.parquet") == ["a", "b"]


def test_parquet_columns_concatenated_and_lists_as_2d(tmp_path):
    for i in range(2):
        vec = pa.FixedSizeListArray.from_arrays(pa.array(np.arange(6, dtype=np.float32) + 10 * i), 3)
        pq.write_table(pa.table({"x": vec, "i": [i, i]}), tmp_path / f"f{i}.parquet")
    cols = read_parquet_columns([tmp_path / "f0.parquet", tmp_path / "f1.parquet"])
    assert cols["x"].shape == (4, 3) and cols["x"].dtype == np.float32
    np.testing.assert_array_equal(cols["x"][2], [10, 11, 12])
    np.testing.assert_array_equal(cols["i"], [0, 0, 1, 1])


def test_column_types_of_extras_and_hf_features():
    assert extra_column_type(True) == pa.bool_() and extra_column_type(np.int32(3)) == pa.int64()
    assert extra_column_type(0.5) == pa.float64() and extra_column_type("side") == pa.string()
    assert extra_column_type(np.arange(3)) == pa.list_(pa.int64())
    assert extra_column_type([1.0, 2.0]) == pa.list_(pa.float64())
    with pytest.raises(ValueError, match="unsupported value"):
        extra_column_type(np.zeros((2, 2)))
    assert hf_feature({"dtype": "int64", "shape": [1]}) == {"dtype": "int64", "_type": "Value"}
    assert hf_feature({"dtype": "float32", "shape": [7]}) == {
        "feature": {"dtype": "float32", "_type": "Value"},
        "length": 7,
        "_type": "List",
    }
