"""Analyse the arm motion and joint torques of a person in skeleton recordings (docs/human.md).

Usage::

    python scripts/analyze_arm.py file=recording.csv                          # one file
    python scripts/analyze_arm.py file=recording.csv side=left subject.body_mass=80 \
        subject.sex=female filter=median fit.method=spline subject.hand_load=2
    python scripts/analyze_arm.py file=recordings/                            # batch mode
    python scripts/analyze_arm.py file=recording_in_mm.csv units=mm           # coordinates in mm

One file: ``arm.csv`` (per-frame angles, velocities, accelerations, torques, positions),
``arm.mot`` (OpenSim motion), ``arm.json`` (summary, quality, settings) and the figures
(``positions/angles/velocities/accelerations/torques.png``, ``stick_figure.gif``) in the
Hydra run directory, whose path is printed. A folder: one subfolder per file plus
``summary.csv`` (range of motion and peak torques per file; files that fail are listed
with their error) and a progress bar. Configuration: ``configs/analyze_arm.yaml``.

A recording whose scale is not a person's (upper arm outside 0.15-0.6 m, frame rate outside
1-1000 Hz) or a body mass outside 20-250 kg is refused with one line on stderr (exit status 2)
that suggests the unit (e.g. ``units=mm``); in batch mode such a file is a failed row of the
summary and the other files are analysed.
"""

from lfd.cli.analyze_arm import *  # noqa: F403  (the entry point's functions, as the tests import them)
from lfd.cli.analyze_arm import cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
