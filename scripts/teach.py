"""Teach by dragging: serve the browser interface for one robot and scene.

Usage::

    python scripts/teach.py robot=wam4 scene=configs/teach/boxes.yaml
    python scripts/teach.py robot=sawyer scene=null port=0     # empty scene, free port

Prints the URL (``http://127.0.0.1:8080`` by default; with ``?token=<secret>`` whenever
``host`` is not loopback, or with ``token=true``); open it in any browser, drag the
gizmo on the tool (3-D mode) or use the 2-D panel, then Export / Send. Configuration:
``configs/teach/teach.yaml``, turned into :class:`lfd.teach.TeachSettings` (every value checked
once; a bad one is one line on stderr and exit status 2); the scene format is described in
``docs/teach.md``.
"""

from lfd.cli.teach import *  # noqa: F403  (the entry point's functions, as the tests import them)
from lfd.cli.teach import cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
