"""``lfd-analyze-arm`` / ``python scripts/analyze_arm.py``: a person's arm motion and joint torques.

The entry point; the repository's ``scripts/analyze_arm.py`` documents the command and is a wrapper of
this module.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.cli import configs_dir, run_app

#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()


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


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="analyze_arm")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    try:
        run(cfg, HydraConfig.get().runtime.output_dir)
    except (ValueError, FileNotFoundError) as e:  # bad input: one line, no traceback
        print(f"analyze_arm: {e}", file=sys.stderr)
        raise SystemExit(2) from None


USAGE = """
lfd-analyze-arm (python scripts/analyze_arm.py): a person's arm motion and torques (configs/analyze_arm.yaml)
  file=FILE|FOLDER                a recording, or a folder of them (batch mode, summary.csv)
  side=right|left   units=m|cm|mm   subject.body_mass=KG subject.sex=male|female subject.hand_load=KG
  filter=butterworth|median|none  fit.method=polynomial|spline
Outputs: outputs/analyze_arm/<date>_<time>/ (arm.csv, arm.mot, arm.json, figures).
"""


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-analyze-arm`` command (``python scripts/analyze_arm.py``): ``--help`` prints :data:`USAGE`."""
    run_app(main, USAGE, argv)


if __name__ == "__main__":
    cli()
