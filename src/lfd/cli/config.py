"""Composing the commands' objects from their Hydra config groups (shared by ``lfd-train``,
``lfd-export`` and ``scripts/generate_data.py``): :func:`instantiate_node`."""

from __future__ import annotations

import re

import hydra
from hydra.errors import InstantiationException
from omegaconf.errors import MissingMandatoryValue

from lfd.checks import one_line

#: A constructor's one-line error about one of its arguments: ``"ReachDataModule.image_size: expected ..."``.
ARGUMENT_ERROR = re.compile(r"\w+\.(\w+): (.*)")


def instantiate_node(group: str, node, **kwargs):
    """``hydra.utils.instantiate(node, **kwargs)`` of the config node ``group`` (e.g. ``"data"``); a
    bad or missing setting of it is a :class:`ValueError` whose one line names the key as the user
    writes it (``data.image_size: expected an int >= 8, got -1``; ``data.root: no value given``), for
    :func:`lfd.cli.user_errors` to print. Other errors pass unchanged."""
    try:
        return hydra.utils.instantiate(node, **kwargs)
    except MissingMandatoryValue as e:
        raise ValueError(f"{e.full_key}: no value given (set {e.full_key}=...)") from None
    except InstantiationException as e:  # the constructor's own line: "Class.key: expected ..."
        if not isinstance(e.__cause__, TypeError | ValueError):
            raise
        message = one_line(str(e.__cause__), limit=None)
        named = ARGUMENT_ERROR.fullmatch(message)
        if named and named.group(1) in node:
            raise ValueError(f"{group}.{named.group(1)}: {named.group(2)}") from None
        raise ValueError(f"{group}: {message}") from None
