"""Fixtures of the teach tests."""

from __future__ import annotations

import pytest
from teach_helpers import BOXES, FakeClock


@pytest.fixture
def boxes_session():
    from lfd.teach import TeachSession

    s = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    yield s
    s.close()
