"""Small JSON files for fitted DMPs, written atomically (:func:`lfd.io.files.write_text_atomic`) and
read within documented bounds: at most :data:`MAX_FILE_BYTES` and :data:`MAX_DEPTH` levels of nesting."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lfd.io.files import write_text_atomic

FORMAT_VERSION = 1
#: The largest DMP file read (bytes): 16 MiB, thousands of times a fitted 7-joint DMP or ProMP.
MAX_FILE_BYTES = 16 << 20
#: The deepest nesting of JSON arrays and objects in a DMP file: 16 (a DMP file written by lfd has
#: at most 5: the file, ``fitted``, a weights array of three dimensions).
MAX_DEPTH = 16


def write_json(path, kind: str, params: dict, fitted: dict | None) -> Path:
    """Write ``{"type", "version", "params", "fitted"}`` to ``path`` atomically.

    Arrays in ``fitted`` are stored as nested lists (floats round-trip exactly).

    Raises:
        ValueError: ``path`` does not end in ``.json`` (the file's name must say its format).
    """
    path = Path(path)
    if path.suffix.lower() != ".json":
        raise ValueError(f"{path}: a DMP file is JSON; give it a .json name (e.g. 'skill.dmp.json')")
    payload = {
        "type": kind,
        "version": FORMAT_VERSION,
        "params": params,
        "fitted": None if fitted is None else {k: np.asarray(v).tolist() for k, v in fitted.items()},
    }
    write_text_atomic(path, json.dumps(payload))
    return path


def read_json(path, kind: str) -> tuple[dict, dict | None]:
    """Read a file written by :func:`write_json` for ``kind``; returns ``(params, fitted)``.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        ValueError: larger than :data:`MAX_FILE_BYTES`, nested deeper than :data:`MAX_DEPTH`, not
            valid JSON, or not a ``kind`` file of a supported version (one line naming the file).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no DMP file at {path}")
    with path.open("rb") as file:
        data = file.read(MAX_FILE_BYTES + 1)  # never more than the limit, whatever the file says
    if len(data) > MAX_FILE_BYTES:
        raise ValueError(
            f"{path} is not a DMP file (more than the {MAX_FILE_BYTES >> 20} MiB a DMP file may have)"
        )
    try:
        payload = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path} is not a DMP file (not UTF-8 JSON text: {exc.reason})") from exc
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from exc
    except RecursionError:  # deeper than Python's parser goes: past MAX_DEPTH too
        raise ValueError(_too_deep(path)) from None
    if _depth(payload) > MAX_DEPTH:
        raise ValueError(_too_deep(path))
    found = payload.get("type") if isinstance(payload, dict) else None
    if found != kind:
        raise ValueError(f"{path} does not hold a {kind} (type field: {found!r})")
    if payload.get("version") != FORMAT_VERSION:
        raise ValueError(
            f"{path}: unsupported format version {payload.get('version')!r}, expected {FORMAT_VERSION}"
        )
    if not isinstance(payload.get("params"), dict):
        raise ValueError(f"{path}: missing 'params' object")
    fitted = payload.get("fitted")
    if fitted is not None and not isinstance(fitted, dict):
        raise ValueError(f"{path}: 'fitted' must be an object or null")
    return payload["params"], fitted


def _too_deep(path: Path) -> str:
    return f"{path} is not a DMP file (JSON nested deeper than the {MAX_DEPTH} levels a DMP file may have)"


def _depth(value) -> int:
    """The nesting depth of parsed JSON (a number or string: 0; ``[1]``: 1), without recursion; the
    walk stops once past :data:`MAX_DEPTH`."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, (list, dict)):
            level += 1
            deepest = max(deepest, level)
            if deepest > MAX_DEPTH:
                return deepest
            values = item.values() if isinstance(item, dict) else item
            stack.extend((v, level) for v in values if isinstance(v, (list, dict)))
    return deepest
