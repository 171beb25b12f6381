"""Image fidelity and read speed of a LeRobot v3.0 export against its lfd source dataset.

    python benchmarks/formats_fidelity.py data/original_s42 data/original_s42.lerobot

Decodes every frame of the export with PyAV (``LeRobotFolder.frames``: seek to
``from_timestamp``, frames at ``from_timestamp + frame_index / fps``), compares it with the
original uint8 frame and prints the PSNR distribution, the decoding rate and the time
``LeRobotDataModule(mode="dmp").setup("fit")`` takes. States and actions are not measured
here: the tests check that they round-trip bit for bit.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from lfd.interop import LeRobotDataModule, LeRobotFolder
from lfd.visuomotor.data import load_dataset
from lfd.visuomotor.data.episodes import SPLITS


def main(src: str, dst: str) -> None:
    data = load_dataset(src)
    order = [r for s in SPLITS for r in data.split(s)]  # the export's episode order
    t = time.perf_counter()
    folder = LeRobotFolder(dst)
    print(f"LeRobotFolder load: {time.perf_counter() - t:.1f} s")
    psnr, decode_s = [], 0.0
    for e, rec in enumerate(order):
        a = rec.frames().astype(np.float64)
        t = time.perf_counter()
        b = folder.frames(e, "observation.images.front").astype(np.float64)
        decode_s += time.perf_counter() - t
        mse = ((a - b) ** 2).mean(axis=(1, 2, 3))
        psnr.extend((10 * np.log10(255.0**2 / np.maximum(mse, 1e-12))).tolist())
    p = np.array(psnr)
    print(
        f"frames {len(p)}: PSNR min {p.min():.2f} dB, p1 {np.percentile(p, 1):.2f}, median {np.median(p):.2f}, "
        f"mean {p.mean():.2f}; decode {decode_s:.1f} s ({len(p) / decode_s:.0f} frames/s)"
    )
    t = time.perf_counter()
    dm = LeRobotDataModule(dst, mode="dmp")
    dm.setup("fit")
    print(
        f"LeRobotDataModule(mode=dmp).setup('fit'): {time.perf_counter() - t:.1f} s, "
        f"train {len(dm.datasets['train'])}, val {len(dm.datasets['val'])}"
    )


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], sys.argv[2])
