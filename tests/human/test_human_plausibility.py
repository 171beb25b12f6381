"""lfd.human.plausibility: the ranges, their boundaries and the unit each message suggests."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human import Skeleton
from lfd.human.plausibility import check_body_mass, check_frame_rate, check_upper_arm, upper_arm_length


def _arm(length: float, rate: float = 30.0, frames: int = 5, right_only: bool = False) -> Skeleton:
    """Shoulders at +-0.2 (scaled with the arm), elbows ``length`` below them."""
    scale = length / 0.3
    names = ["shoulder_right", "elbow_right"] + ([] if right_only else ["shoulder_left", "elbow_left"])
    pos = np.zeros((frames, len(names), 3))
    pos[:, 0] = [0.2 * scale, 0.0, 0.0]
    pos[:, 1] = [0.2 * scale, -length, 0.0]
    if not right_only:
        pos[:, 2] = [-0.2 * scale, 0.0, 0.0]
        pos[:, 3] = [-0.2 * scale, -length, 0.0]
    return Skeleton(t=np.arange(frames) / rate, names=tuple(names), positions=pos, source="x")


def test_upper_arm_median_pools_both_sides_and_prefers_tracked_frames():
    sk = _arm(0.3, frames=7)
    sk.positions[:3, 1, 1] = -30.0  # three wild right-elbow frames, tracked: the median still holds
    assert upper_arm_length(sk) == pytest.approx(0.3)
    tracked = sk.tracked.copy()
    tracked[:, 1] = False  # the right elbow never tracked: only the left arm counts
    sk = sk.replace(tracked=tracked)
    sk.positions[:, 1, 1] = -30.0
    assert upper_arm_length(sk) == pytest.approx(0.3)
    no_arm = Skeleton(t=np.arange(3.0), names=("neck",), positions=np.zeros((3, 1, 3)))
    assert upper_arm_length(no_arm) is None
    check_upper_arm(no_arm, "x", 1.0)  # nothing to measure: the analysis names the missing joints


@pytest.mark.parametrize(
    ("length", "scale", "hint"),
    [
        (300.0, 1.0, "is the file in millimetres? pass units=mm"),
        (30.0, 1.0, "is the file in centimetres? pass units=cm"),
        (0.003, 0.01, "is the file in metres? pass units=m"),  # read as cm, written in m
        (0.0003, 0.001, "is the file in metres? pass units=m"),
        (3.0, 0.01, "is the file in millimetres? pass units=mm"),  # read as cm, written in mm
        (5.0, 1.0, "check the file's length unit"),  # no unit fits
    ],
)
def test_upper_arm_out_of_range_suggests_the_fitting_unit(length, scale, hint):
    with pytest.raises(ValueError, match=r"^rec\.csv: upper arm .* m: outside 0\.15-0\.6 m; ") as info:
        check_upper_arm(_arm(length, right_only=True), "rec.csv", lambda: scale)
    assert hint in str(info.value) and "\n" not in str(info.value)


def test_boundaries_are_inclusive():
    for length in (0.15, 0.6):
        check_upper_arm(_arm(length), "x", 1.0)
    for rate in (1.0, 1000.0):
        check_frame_rate(_arm(0.3, rate=rate), "x", "time column")
    for mass in (20, 250.0):
        check_body_mass(mass)
    for length in (0.149, 0.601):
        with pytest.raises(ValueError, match="upper arm"):
            check_upper_arm(_arm(length), "x", 1.0)


def test_frame_rate_messages_name_the_time_source():
    with pytest.raises(ValueError, match=r"^f\.csv: time column gives 3e\+08 frames/s .*must be in seconds$"):
        check_frame_rate(_arm(0.3, rate=3e8), "f.csv", "time column")
    with pytest.raises(ValueError, match=r"is it in milliseconds \(30 Hz\)\?"):
        check_frame_rate(_arm(0.3, rate=0.03), "f.csv", "time column")
    with pytest.raises(ValueError, match=r"^k\.csv: rate=5000 gives 5000 frames/s.*pass rate= in Hz"):
        check_frame_rate(_arm(0.3, rate=5000), "k.csv", "rate=5000")
    check_frame_rate(_arm(0.3, rate=1e9, frames=1), "one frame has no rate", "time column")


def test_body_mass_range_and_grams_hint():
    with pytest.raises(ValueError, match=r"^body_mass 75000 is outside 20-250 kg; .*grams\? 75 kg"):
        check_body_mass(75000.0)
    with pytest.raises(ValueError, match=r"body_mass 7\.5 is outside 20-250 kg; give body_mass in kg$"):
        check_body_mass(7.5)
    for bad in ("75", float("nan"), True):
        with pytest.raises(ValueError, match="body_mass must be a number of kg"):
            check_body_mass(bad)
