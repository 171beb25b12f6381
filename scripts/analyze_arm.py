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

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")


def analysis_options(cfg: DictConfig) -> dict:
    """Keyword arguments of :func:`lfd.human.analyze_arm` from the config."""
    return dict(
        side=cfg.side,
        body_mass=float(cfg.subject.body_mass),
        sex=cfg.subject.sex,
        hand_load=float(cfg.subject.hand_load),
        hand_length=None if cfg.subject.hand_length is None else float(cfg.subject.hand_length),
        filter=cfg.filter.kind,
        cutoff=float(cfg.filter.cutoff),
        filter_order=int(cfg.filter.order),
        median_kernel=int(cfg.filter.kernel),
        hampel=bool(cfg.hampel.enabled),
        hampel_window=int(cfg.hampel.window),
        hampel_sigma=float(cfg.hampel.sigma),
        max_gap=float(cfg.gaps.max_gap),
        use_inferred=bool(cfg.gaps.use_inferred),
        repair_swaps_=bool(cfg.gaps.repair_swaps),
        bone_tolerance=float(cfg.gaps.bone_tolerance),
        fit=cfg.fit.method,
        poly_max_order=int(cfg.fit.poly_max_order),
        poly_window=float(cfg.fit.poly_window),
        spline_cutoff=None if cfg.fit.spline_cutoff is None else float(cfg.fit.spline_cutoff),
        singular_deg=float(cfg.ik.singular_deg),
    )


def save_options(cfg: DictConfig) -> dict:
    """Keyword arguments of :func:`lfd.human.batch.analyze_file` (reader, analysis, outputs)."""
    return dict(
        format=cfg.format,
        units=cfg.units,
        reader=OmegaConf.to_container(cfg.reader, resolve=True) if cfg.reader else {},
        analysis=analysis_options(cfg),
        plots=bool(cfg.outputs.plots),
        gif=bool(cfg.outputs.gif),
        gif_frames=int(cfg.outputs.gif_frames),
    )


def run(cfg: DictConfig, out_dir: str | Path) -> Path:
    """Run the analysis for ``cfg.file`` (a file or a folder) writing into ``out_dir``; returns it."""
    from lfd.human.batch import SUMMARY_FILE, analyze_file, analyze_folder

    out = Path(out_dir)
    source = Path(str(cfg.file))
    if not source.exists():
        raise FileNotFoundError(f"file={source}: no such file or folder")
    if source.is_file():
        s = analyze_file(source, out, **save_options(cfg)).summary()
        print(
            f"[lfd] {source}: {s['frames']} frames, {cfg.side} arm; elevation {s['elevation_min_deg']:.0f} to "
            f"{s['elevation_max_deg']:.0f} deg (plane of elevation {s['plane_of_elevation_min_deg']:.0f} to "
            f"{s['plane_of_elevation_max_deg']:.0f} deg), elbow {s['elbow_flexion_rom_deg']:.0f} deg ROM; "
            f"peak shoulder elevation torque {s['elevation_peak_torque_Nm']:.1f} N m"
        )
    else:
        rows = analyze_folder(source, out, pattern=cfg.pattern, **save_options(cfg))
        ok = sum(r["status"] == "ok" for r in rows)
        print(f"[lfd] {ok}/{len(rows)} files analysed; summary: {out / SUMMARY_FILE}")
    print(f"[lfd] outputs in {out}")
    return out


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="analyze_arm")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    try:
        run(cfg, HydraConfig.get().runtime.output_dir)
    except (ValueError, FileNotFoundError) as e:  # bad input: one line, no traceback
        print(f"analyze_arm: {e}", file=sys.stderr)
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
