"""Low-level file I/O for datasets: atomic writes, byte-deterministic npz, checksums,
exports published atomically.

Every file is written to a temporary file in the destination folder and moved into
place with :func:`os.replace`, so a reader (or a resumed generation) sees either the old
file, the complete new one, or nothing. A whole export (a folder or one file) is written
into a temporary sibling folder and renamed into place by :func:`publish_output`, which
replaces an existing output only when it carries lfd's marker of the same kind.
``.npz`` files are written with fixed zip timestamps, so the same arrays always give the
same bytes (``numpy.savez_compressed`` stamps the current time into the archive).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import shutil
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
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


def read_text(path: Path) -> str:
    """The text of a user's file, decoded as UTF-8 (a byte-order mark is dropped).

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the bytes are not UTF-8 text (one line naming the file).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no file at {path}")
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ValueError(
            f"{path}: not UTF-8 text (byte {e.start}: {e.reason}); expected a text file"
        ) from None


#: Largest YAML file :func:`read_yaml` reads (bytes).
MAX_YAML_BYTES = 1 << 20
#: Deepest nesting of lists and mappings :func:`load_yaml` accepts.
MAX_YAML_DEPTH = 64


class YamlError(ValueError):
    """A user's YAML file that lfd will not use: unreadable, not YAML, or using a feature
    refused for safety (aliases, duplicate keys, deep nesting); the message names the file."""


def show(value: Any, limit: int = 80) -> str:
    """A ``repr`` of ``value`` for a message, at most ``limit`` characters; the work is bounded
    too (a huge list or number is not rendered in full first)."""
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother, r.maxlong = 3, limit, limit, 4000
    r.maxlist = r.maxtuple = r.maxdict = r.maxset = r.maxfrozenset = r.maxdeque = r.maxarray = 8
    try:
        text = r.repr(value)
    except Exception:
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _yaml_problem(e: Exception) -> str:
    """One line saying where and why PyYAML gave up."""
    import yaml

    if isinstance(e, yaml.reader.ReaderError):
        char = ""
        if isinstance(e.character, int):
            char = f"#x{e.character:04x}, "
        elif isinstance(e.character, str):
            char = f"#x{ord(e.character):04x}, "
        return f"not UTF-8 or UTF-16 text (position {e.position}: {char}{e.reason}); save it as UTF-8 YAML"
    mark = getattr(e, "problem_mark", None)
    problem = getattr(e, "problem", None) or getattr(e, "context", None) or type(e).__name__
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    return f"not valid YAML{where}: {' '.join(str(problem).split())[:200]}"


def _safe_loader_class():
    """``yaml.SafeLoader`` that also refuses aliases, duplicate keys and deep nesting."""
    import yaml
    from yaml.nodes import MappingNode, ScalarNode

    class _Refused(yaml.YAMLError):
        def __init__(self, problem: str, mark) -> None:
            super().__init__(problem)
            self.problem, self.problem_mark = problem, mark

    class SafeLoader(yaml.SafeLoader):
        _depth = 0

        def compose_node(self, parent, index):
            if self.check_event(yaml.AliasEvent):
                event = self.peek_event()
                raise _Refused(
                    f"alias *{event.anchor} refused (YAML anchors and aliases are not accepted: "
                    "write each value out)",
                    event.start_mark,
                )
            self._depth += 1
            try:
                if self._depth > MAX_YAML_DEPTH:
                    raise _Refused(
                        f"lists and mappings nested more than {MAX_YAML_DEPTH} deep",
                        self.peek_event().start_mark,
                    )
                return super().compose_node(parent, index)
            finally:
                self._depth -= 1

        def construct_mapping(self, node, deep=False):
            if isinstance(node, MappingNode):
                seen: set = set()
                for key_node, _ in node.value:
                    if not isinstance(key_node, ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                        continue
                    key = self.construct_object(key_node)
                    try:
                        duplicate = key in seen
                    except TypeError:
                        continue  # unhashable: the base class says so
                    if duplicate:
                        raise _Refused(
                            f"duplicate key {show(key)} (each key may appear once in a mapping)",
                            key_node.start_mark,
                        )
                    seen.add(key)
            return super().construct_mapping(node, deep)

    return SafeLoader


def load_yaml(data: str | bytes, source: str | os.PathLike) -> Any:
    """Parse a user's YAML text (``bytes``: UTF-8, or UTF-16 with a byte-order mark) safely.

    Like ``yaml.safe_load`` (no Python object is built from a tag), and also refused:
    aliases (``*name``; their expansion is unbounded work: a few hundred bytes can stand for
    billions of values), a key repeated in one mapping (YAML would silently keep the last),
    lists and mappings nested more than :data:`MAX_YAML_DEPTH` deep. The work is thus bounded
    by the size of ``data``.

    Raises:
        YamlError: one line ``"<source>: <why>"`` (with line and column where known).
    """
    import yaml

    loader = None
    try:
        loader = _safe_loader_class()(data)  # the reader checks the encoding here
        return loader.get_single_data()
    except yaml.YAMLError as e:
        raise YamlError(f"{source}: {_yaml_problem(e)}") from None
    except (ValueError, RecursionError) as e:
        raise YamlError(f"{source}: not valid YAML: {type(e).__name__}") from None
    finally:
        if loader is not None:
            loader.dispose()


def read_yaml(path: str | os.PathLike, *, max_bytes: int = MAX_YAML_BYTES, what: str = "a YAML file") -> Any:
    """The parsed content of the user's YAML file ``path`` (:func:`load_yaml`), at most
    ``max_bytes`` long (default :data:`MAX_YAML_BYTES`); ``what`` names the file's kind in messages.

    Raises:
        FileNotFoundError: nothing at ``path``.
        YamlError: one line naming the file: not a regular file, over ``max_bytes``,
            unreadable, or refused by :func:`load_yaml`.
    """
    path = Path(path)
    if not (path.exists() or path.is_symlink()):
        raise FileNotFoundError(f"no file at {path}")
    if not path.is_file():
        raise YamlError(f"{path}: not a regular file; expected {what}")
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise YamlError(f"{path}: {size} bytes; {what} has at most {max_bytes}")
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise YamlError(f"{path}: cannot be read ({e.strerror or e})") from None
    if len(raw) > max_bytes:
        raise YamlError(f"{path}: more than {max_bytes} bytes; {what} has at most {max_bytes}")
    return load_yaml(raw, path)


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


#: Marker file lfd writes at the top of every export folder: ``{"kind": ..., "lfd_version": ...}``.
EXPORT_MARKER = ".lfd-export.json"
#: Infix of the temporary sibling folders of :func:`publish_output`: ``.<name>.lfd-partial-<pid>-<random>``.
PARTIAL_INFIX = ".lfd-partial-"
_REPLACED = "replaced"


class OutputRefused(ValueError):
    """An output that lfd will not replace: it was not written by lfd as this kind of export,
    or it is (or holds) the source, the current or the home folder."""


def export_marker(kind: str) -> dict[str, str]:
    """The marker of an lfd export of ``kind``: ``{"kind": kind, "lfd_version": ...}``."""
    from lfd import __version__

    return {"kind": kind, "lfd_version": __version__}


def read_export_marker(folder: Path) -> dict[str, Any] | None:
    """The :data:`EXPORT_MARKER` of ``folder`` (a dict with a string ``"kind"``), or None when
    it has none or an unreadable one."""
    try:
        marker = json.loads((Path(folder) / EXPORT_MARKER).read_text())
    except (OSError, ValueError):
        return None
    return marker if isinstance(marker, dict) and isinstance(marker.get("kind"), str) else None


def _pid_alive(pid: int) -> bool:
    if os.name != "posix" or pid == os.getpid():
        return True  # cannot tell (or this very process): leave its folder alone
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _clean_leftovers(target: Path, kind: str) -> None:
    """Remove temporary siblings of ``target`` left by an interrupted :func:`publish_output` of
    ``kind``: named like ours, holding our partial marker, their process gone. An output moved
    aside for replacement is put back first when ``target`` is missing."""
    pattern = re.compile(re.escape(f".{target.name}{PARTIAL_INFIX}") + r"(\d+)-[^/]+")
    for folder in target.parent.iterdir():
        m = pattern.fullmatch(folder.name)
        if not m or folder.is_symlink() or not folder.is_dir():
            continue
        marker = read_export_marker(folder)
        if not marker or marker.get("kind") != kind or not marker.get("partial"):
            continue
        if _pid_alive(int(m.group(1))):
            continue
        aside = folder / _REPLACED
        if aside.is_dir() and not (target.exists() or target.is_symlink()):
            os.rename(aside, target)
        shutil.rmtree(folder, ignore_errors=True)


def _refuse_inside(target: Path, protect: Iterable[Path], who: str) -> None:
    """Refuse a ``target`` that lies inside one of ``protect`` (an output never goes inside an input)."""
    resolved = target.resolve()
    for p in protect:
        source = Path(p).resolve()
        if resolved != source and resolved.is_relative_to(source):
            raise OutputRefused(
                f"{who}: refusing to write {target}: it lies inside the source {p} (choose an output outside it)"
            )


def check_output(
    target: Path,
    kind: str,
    *,
    overwrite: bool,
    protect: Iterable[Path] = (),
    kind_of: Callable[[Path], str | None] | None = None,
    who: str = "export",
) -> bool:
    """Whether ``target`` exists and may be replaced by an export of ``kind``.

    A folder export is recognised by its :data:`EXPORT_MARKER`, a file export by
    ``kind_of(path)`` (the kind recorded inside the file, or None).

    Returns:
        False when nothing is at ``target``; True when an lfd export of ``kind`` is there
        and ``overwrite`` is set.

    Raises:
        FileExistsError: ``target`` exists and ``overwrite`` is not set.
        OutputRefused: ``target`` lies inside one of ``protect`` (the sources; whether or not it
            exists), or it exists and is a symbolic link, is or holds one of ``protect``, the
            current folder or the home folder, or carries no marker of ``kind``.
    """
    target, protect = Path(os.path.abspath(target)), list(protect)
    _refuse_inside(target, protect, who)
    if not (target.exists() or target.is_symlink()):
        return False
    if not overwrite:
        raise FileExistsError(f"{who}: {target} exists (pass overwrite=True to replace it)")
    refuse = f"{who}: refusing to overwrite {target}"
    if target.is_symlink():
        raise OutputRefused(f"{refuse}: it is a symbolic link (lfd replaces only what it wrote)")
    resolved = target.resolve()
    for name, p in [*(("the source", Path(p)) for p in protect), ("the current folder", Path.cwd())]:
        if p.resolve().is_relative_to(resolved):
            raise OutputRefused(f"{refuse}: it is or holds {name} {p}")
    if Path.home().resolve().is_relative_to(resolved):
        raise OutputRefused(f"{refuse}: it is or holds the home folder {Path.home()}")
    if kind_of is None:
        found = (read_export_marker(target) or {}).get("kind") if target.is_dir() else None
        detail = f"no {EXPORT_MARKER} in it" if target.is_dir() else "a file, not a folder"
    else:
        found = kind_of(target) if target.is_file() else None
        detail = "no lfd marker in the file" if target.is_file() else "not a file"
    if found != kind:
        detail = f"its marker says {found!r}" if found else detail
        raise OutputRefused(
            f"{refuse}: it is not an lfd {kind} export ({detail}); lfd replaces only its own exports: "
            "remove it yourself or choose another output"
        )
    return True


@contextmanager
def publish_output(
    target: Path,
    kind: str,
    *,
    overwrite: bool = False,
    protect: Iterable[Path] = (),
    kind_of: Callable[[Path], str | None] | None = None,
    who: str = "export",
) -> Iterator[Path]:
    """Write an export of ``kind`` (a folder, or one file when ``kind_of`` is given) and move it
    to ``target`` only once it is complete.

    Yields a path that does not exist yet, inside a new temporary sibling folder of ``target``
    (``.<name>.lfd-partial-<pid>-<random>``, marked ``partial``); the body writes the export
    there. On a normal exit a folder export gets its :data:`EXPORT_MARKER` and is renamed to
    ``target`` (an old one is first renamed aside, then deleted), a file export replaces
    ``target`` with :func:`os.replace` (the file must record ``kind`` itself, read back by
    ``kind_of``). On an exception the temporary folder is removed and ``target`` is left as
    it was. Leftovers of an interrupted earlier run for the same ``target`` and ``kind`` are
    removed first (see :func:`check_output` for what may be replaced). Of two runs racing to
    publish the same new ``target``, exactly one succeeds; the other removes its temporary
    folder and raises :class:`FileExistsError` (nothing of the winner's is replaced).

    Raises:
        FileExistsError, OutputRefused: from :func:`check_output`, before anything is written;
            FileExistsError also when another process published ``target`` first.
    """
    target, protect = Path(os.path.abspath(target)), list(protect)
    _refuse_inside(target, protect, who)  # before any folder is made
    target.parent.mkdir(parents=True, exist_ok=True)
    _clean_leftovers(target, kind)
    replace = check_output(target, kind, overwrite=overwrite, protect=protect, kind_of=kind_of, who=who)
    container = Path(
        tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}{PARTIAL_INFIX}{os.getpid()}-")
    )
    try:
        write_json_atomic(container / EXPORT_MARKER, {**export_marker(kind), "partial": True})
        payload = container / target.name
        yield payload
        lost = FileExistsError(
            f"{who}: {target} was written by another process meanwhile; it is kept as it is"
        )
        if kind_of is not None:
            if replace:
                os.replace(payload, target)
                return
            try:  # a hard link fails if the name exists: no other run's file is replaced
                os.link(payload, target)
            except FileExistsError:
                raise lost from None
            except OSError:  # a file system without hard links: check, then rename
                if target.exists() or target.is_symlink():
                    raise lost from None
                os.replace(payload, target)
            return
        write_json_atomic(payload / EXPORT_MARKER, export_marker(kind))
        if replace:
            os.rename(target, container / _REPLACED)
        try:
            os.rename(payload, target)  # fails if another run published a folder there meanwhile
        except BaseException as e:
            if replace:
                os.rename(container / _REPLACED, target)
            if isinstance(e, OSError) and not replace and (target.exists() or target.is_symlink()):
                raise lost from None
            raise
    finally:
        shutil.rmtree(container, ignore_errors=True)
