"""Low-level file I/O for datasets: atomic writes, byte-deterministic npz, checksums.

Every file is written to a temporary file in the destination folder and moved into
place with :func:`os.replace`, so a reader (or a resumed generation) sees either the old
file, the complete new one, or nothing. ``.npz`` files are written with fixed zip
timestamps, so the same arrays always give the same bytes (``numpy.savez_compressed``
stamps the current time into the archive).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

#: Version of the on-disk layout described in ``data/README.md``.


class DatasetError(ValueError):
    """A dataset on disk is missing, incomplete, corrupt or was made with another config."""


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder + rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`write_bytes_atomic`); returns the path."""
    write_bytes_atomic(path, text.encode("utf-8"))
    return Path(path)


def json_bytes(obj: Any) -> bytes:
    """Canonical JSON encoding (sorted keys, 2-space indent, trailing newline)."""
    return (json.dumps(obj, indent=2, sort_keys=True) + "\n").encode()


def write_json_atomic(path: Path, obj: Any) -> None:
    write_bytes_atomic(path, json_bytes(obj))


def read_json(path: Path) -> Any:
    """Parse a JSON file; a missing or unparsable file raises :class:`DatasetError`
    naming it."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError as e:
        raise DatasetError(f"missing file {path}") from e
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise DatasetError(f"corrupt JSON file {path}: {e}") from e


_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


def npz_bytes(arrays: Mapping[str, np.ndarray]) -> bytes:
    """Compressed ``.npz`` archive of ``arrays`` (readable by :func:`numpy.load`), keys in
    the given order, fixed timestamps: identical arrays give identical bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as zf:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=_ZIP_EPOCH)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            member = io.BytesIO()
            np.lib.format.write_array(member, np.asarray(value).copy(order="C"), allow_pickle=False)
            zf.writestr(info, member.getvalue(), compresslevel=6)
    return buf.getvalue()


def write_npz_atomic(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    write_bytes_atomic(path, npz_bytes(arrays))


def sha256_file(path: Path, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()
