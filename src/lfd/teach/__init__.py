"""Teach by dragging: program an arm in a browser 3-D scene, or with a 2-D joint panel.

The thesis' VARM teaching system, described in docs/teach.md. :class:`TeachSession` is the
whole logic (IK, collisions, recording, export, Send) and runs without a browser;
:class:`~lfd.teach.server.TeachServer` puts it behind a local viser web app
(``python scripts/teach.py robot=wam4 scene=configs/teach/boxes.yaml``). The settings of both are a
:class:`TeachSettings` (``configs/teach/teach.yaml``, checked when built); the robots offered are the
robot catalogue's entries marked ``teach`` (:func:`teach_robots`).

Example (runnable)::

    import numpy as np
    from lfd.teach import TeachSession

    s = TeachSession(robot="wam4", scene="configs/teach/boxes.yaml")
    r = s.drag(s.tool_position + [0.0, 0.0, 0.05])   # DragResult(accepted, q, in_collision, reached_goal, ...)
    s.recorded.t.shape, s.recorded.q.shape          # (2,), (2, 4)
    s.set_joints(s.q)                               # the 2-D panel's sliders (same collision rule)
"""

from .scene import Box, Goal, TeachScene, load_scene
from .session import DragResult, Recording, TeachSession
from .settings import IKSettings, TeachSettings, teach_robots

__all__ = [
    "Box",
    "DragResult",
    "Goal",
    "IKSettings",
    "Recording",
    "TeachScene",
    "TeachSession",
    "TeachSettings",
    "load_scene",
    "teach_robots",
]
