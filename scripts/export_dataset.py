"""Export a dataset as LeRobot v3.0 or robomimic HDF5 (``configs/export_dataset.yaml``)::

    python scripts/export_dataset.py data=original format=lerobot out=data/original.lerobot
    python scripts/export_dataset.py data=original format=robomimic out=data/original.hdf5
    python scripts/export_dataset.py format=lerobot lerobot.codec=h264     # H.264 instead of AV1
    python scripts/export_dataset.py data=metaworld task=reach-v3 format=lerobot   # Meta-World demonstrations

The dataset is generated first when it is missing (like ``train.py``), otherwise verified
against its manifest. A progress bar shows the episodes; the time taken is printed.
``overwrite=true`` replaces only an earlier lfd export of the same format (never the dataset
or a folder holding it); a refused output or a bad dataset ends with one line on stderr, rc 2.
"""

from lfd.cli.export_dataset import *  # noqa: F403  (the entry point's functions, as the tests import them)
from lfd.cli.export_dataset import cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
