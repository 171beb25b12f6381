"""``lfd-analyze-arm`` / ``python scripts/analyze_arm.py``: a person's arm motion and joint torques.

The entry point; the repository's ``scripts/analyze_arm.py`` documents the command and is a wrapper of
this module.
"""

from __future__ import annotations

import math
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.cli import configs_dir, run_app, user_errors
from lfd.io.files import show

#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()


def option(cfg: DictConfig, key: str, kind: type, *, optional: bool = False):
    """The config value at ``key`` (dotted) as ``kind`` (``float``: finite; ``int``: whole;
    ``bool``: true/false), ``None`` when ``optional`` and null.

    Raises:
        ValueError: one line naming ``key``, the expected kind and the value given.
    """
    value = OmegaConf.select(cfg, key)
    if value is None and optional:
        return None
    expected = {float: "a finite number", int: "a whole number", bool: "true or false"}[kind]
    if optional:
        expected += " or null"
    ok = isinstance(value, bool) if kind is bool else not isinstance(value, bool)
    if ok and kind is not bool:
        try:
            number = float(value)
            ok = math.isfinite(number) and (kind is float or number.is_integer())
        except (TypeError, ValueError, OverflowError):
            ok = False
    if not ok:
        raise ValueError(f"{key} must be {expected}, got {show(value)}")
    return value if kind is bool else kind(float(value)) if kind is int else float(value)


def analysis_options(cfg: DictConfig) -> dict:
    """Keyword arguments of :func:`lfd.human.analyze_arm` from the config (a bad value: a
    ``ValueError`` naming its key, :func:`option`)."""
    return dict(
        side=cfg.side,
        body_mass=option(cfg, "subject.body_mass", float),
        sex=cfg.subject.sex,
        hand_load=option(cfg, "subject.hand_load", float),
        hand_length=option(cfg, "subject.hand_length", float, optional=True),
        filter=cfg.filter.kind,
        cutoff="auto" if cfg.filter.cutoff == "auto" else option(cfg, "filter.cutoff", float),
        filter_order=option(cfg, "filter.order", int),
        median_kernel=option(cfg, "filter.kernel", int),
        hampel=option(cfg, "hampel.enabled", bool),
        hampel_window=option(cfg, "hampel.window", int),
        hampel_sigma=option(cfg, "hampel.sigma", float),
        max_gap=option(cfg, "gaps.max_gap", float),
        use_inferred=option(cfg, "gaps.use_inferred", bool),
        repair_swaps_=option(cfg, "gaps.repair_swaps", bool),
        bone_tolerance=option(cfg, "gaps.bone_tolerance", float),
        repair_frames=option(cfg, "gaps.repair_frames", bool),
        fit=cfg.fit.method,
        poly_max_order=option(cfg, "fit.poly_max_order", int),
        poly_window=option(cfg, "fit.poly_window", float),
        spline_cutoff=option(cfg, "fit.spline_cutoff", float, optional=True),
        singular_deg=option(cfg, "ik.singular_deg", float),
    )


def save_options(cfg: DictConfig) -> dict:
    """Keyword arguments of :func:`lfd.human.batch.analyze_file` (reader, analysis, outputs)."""
    return dict(
        format=cfg.format,
        units=cfg.units,
        reader=OmegaConf.to_container(cfg.reader, resolve=True) if cfg.reader else {},
        analysis=analysis_options(cfg),
        plots=option(cfg, "outputs.plots", bool),
        gif=option(cfg, "outputs.gif", bool),
        gif_frames=option(cfg, "outputs.gif_frames", int),
    )


def run(cfg: DictConfig, out_dir: str | Path) -> Path:
    """Run the analysis for ``cfg.file`` (a file or a folder) writing into ``out_dir``; returns it."""
    from lfd.human.batch import SUMMARY_FILE, analyze_file, analyze_folder

    out = Path(out_dir)
    source = Path(str(cfg.file))
    if not source.exists():
        raise FileNotFoundError(f"file={source}: no such file or folder")
    if not (source.is_file() or source.is_dir()):
        raise ValueError(
            f"file={source}: not a regular file or a folder (a pipe or device?); expected a recording"
        )
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
        skipped = sum(r["status"].startswith("skipped") for r in rows)
        print(
            f"[lfd] {ok}/{len(rows)} files analysed and written ({len(rows) - ok - skipped} failed, "
            f"{skipped} skipped); summary: {out / SUMMARY_FILE}"
        )
    print(f"[lfd] outputs in {out}")
    return out


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="analyze_arm")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    with user_errors("analyze_arm"):  # bad input: one line, no traceback, exit 2
        run(cfg, HydraConfig.get().runtime.output_dir)


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
