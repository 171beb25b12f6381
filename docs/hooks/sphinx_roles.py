"""mkdocs hook: the docstrings' Sphinx roles (``:func:`name```) shown as plain code in the API pages.

The docstrings are read in Python's ``help()`` and in editors as well, where the roles are common;
mkdocstrings renders Markdown, which has no roles, so ``:func:`` would show literally before the name.
``~lfd.x.Name`` (Sphinx's "last component only") becomes ``Name``.
"""

from __future__ import annotations

import re

ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj|const):<code>(~?)([^<]*)</code>")


def _code(m: re.Match) -> str:
    name = m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2)
    return f"<code>{name}</code>"


def on_page_content(html: str, **_) -> str:
    return ROLE.sub(_code, html)
