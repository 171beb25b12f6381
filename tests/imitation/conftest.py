"""The real test videos of tests/human (fetched once from published wheels, cached)."""

from tests.human.conftest import mediapipe_ok, pose2sim_demo, sports2d_video  # noqa: F401
