"""Small JSON files for fitted DMPs, written atomically (:func:`lfd.io.files.write_text_atomic`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lfd.io.files import write_text_atomic

FORMAT_VERSION = 1


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
        ValueError: not valid JSON, or not a ``kind`` file of a supported version.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no DMP file at {path}")
    try:
        payload = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path} is not a DMP file (not UTF-8 JSON text: {exc.reason})") from exc
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from exc
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
