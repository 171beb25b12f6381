"""The server's handlers without a browser, for every teachable robot."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.teach import TeachSession, teach_robots
from lfd.teach.server import TeachServer


@pytest.mark.parametrize("robot", teach_robots())
def test_server_handles_drags_and_buttons(robot, tmp_path):
    session = TeachSession(robot=robot, scene=None)
    server = TeachServer(session, port=0, export_dir=tmp_path)
    try:
        assert server.url.startswith("http://127.0.0.1:")
        # every URDF link with shapes gets a scene frame
        assert len(server.view.link_nodes) == session.n_dof and server.view.visuals
        p0 = session.tool_position
        for k in range(1, 11):
            r = server.handle_drag(p0 + [0.0, 0.0, 0.01 * k])
            assert r.accepted
        assert len(session.recorded) == 11
        np.testing.assert_allclose(
            server.view.link_nodes[-1].position, session.kin.frames(session.q)[-2, :3, 3]
        )
        # a target far out of reach: refused or best effort, marker red, ghost shown
        r = server.handle_drag(p0 + [3.0, 0.0, 0.0])
        assert (
            not r.reachable and tuple(server.view.marker.color) == (220, 40, 40) and server.view.ghost.visible
        )
        server._run(server._stop)
        server._run(server._export)
        assert server.last_export is not None and server.last_export["dmp"].is_file()
        server._run(server._send)
        assert session.last_send is not None and server.view.executed_line is not None
        assert "final error" in server.status.content
    finally:
        server.close()
        session.close()
