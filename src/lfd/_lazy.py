"""Lazy package exports (PEP 562): a package names what it offers without importing it.

Used by packages whose submodules pull in heavy or optional dependencies (PyBullet,
Lightning), so that importing one light submodule does not load them all.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from importlib import import_module


def exports(groups: Mapping[str, Iterable[str]]) -> dict[str, str]:
    """``{name: submodule}`` from ``{submodule: names}``."""
    return {name: module for module, names in groups.items() for name in names}


def lazy_getattr(
    package: str, names: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """Module-level ``__getattr__`` and ``__dir__`` for ``package`` that import
    ``<package>.<names[name]>`` (or ``names[name]`` itself when it starts with ``lfd.``) on the
    first access of ``name``."""

    def __getattr__(name: str):
        if name in names:
            module = names[name]
            return getattr(
                import_module(module if module.startswith("lfd.") else f"{package}.{module}"), name
            )
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(names)

    return __getattr__, __dir__
