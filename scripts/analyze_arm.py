"""Analyse the arm motion and joint torques of a person in skeleton recordings (docs/human.md).

Usage::

    python scripts/analyze_arm.py file=recording.csv                          # one file
    python scripts/analyze_arm.py file=recording.csv side=left subject.body_mass=80 \
        subject.sex=female filter=median fit.method=spline subject.hand_load=2
    python scripts/analyze_arm.py file=recordings/                            # batch mode

One file: ``arm.csv`` (per-frame angles, velocities, accelerations, torques, positions),
``arm.mot`` (OpenSim motion), ``arm.json`` (summary, quality, settings) and the figures
(``positions/angles/velocities/accelerations/torques.png``, ``stick_figure.gif``) in the
Hydra run directory, whose path is printed. A folder: one subfolder per file plus
``summary.csv`` (range of motion and peak torques per file; files that fail are listed
with their error) and a progress bar. Configuration: ``configs/analyze_arm.yaml``.
"""

from __future__ import annotations

import csv
import fnmatch
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

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


def analyze_file(path: Path, cfg: DictConfig, out_dir: Path):
    """Read, analyse and write all outputs of one file into ``out_dir``; returns the ArmAnalysis."""
    from lfd.human import analyze_arm, read_skeleton

    reader = OmegaConf.to_container(cfg.reader, resolve=True) if cfg.reader else {}
    skeleton = read_skeleton(path, format=cfg.format, **reader)
    result = analyze_arm(skeleton, **analysis_options(cfg))
    result.save(
        out_dir,
        plots=bool(cfg.outputs.plots),
        gif=bool(cfg.outputs.gif),
        gif_frames=int(cfg.outputs.gif_frames),
    )
    return result


def _files(folder: Path, pattern: str | None) -> list[Path]:
    from lfd.human.readers import iter_skeleton_files

    if pattern:
        return sorted(
            p
            for p in folder.rglob("*")
            if p.is_file() and fnmatch.fnmatch(str(p.relative_to(folder)), pattern)
        )
    return list(iter_skeleton_files(folder))


def run(cfg: DictConfig, out_dir: str | Path) -> Path:
    """Run the analysis for ``cfg.file`` (a file or a folder) writing into ``out_dir``; returns it."""
    out = Path(out_dir)
    source = Path(str(cfg.file))
    if not source.exists():
        raise FileNotFoundError(f"file={source}: no such file or folder")
    if source.is_file():
        result = analyze_file(source, cfg, out)
        s = result.summary()
        print(f"[lfd] {source}: {s['frames']} frames, {cfg.side} arm; ROM abduction {s['abduction_rom_deg']:.0f} deg, "
              f"flexion {s['flexion_rom_deg']:.0f} deg, elbow {s['elbow_flexion_rom_deg']:.0f} deg; "
              f"peak shoulder flexion torque {s['flexion_peak_torque_Nm']:.1f} N m")  # fmt: skip
        print(f"[lfd] outputs in {out}")
        return out
    files = _files(source, cfg.pattern)
    if not files:
        raise FileNotFoundError(f"file={source}: no skeleton files found (pattern={cfg.pattern})")
    rows = []
    for path in tqdm(files, desc="analyse", unit="file"):
        rel = path.relative_to(source)
        name = str(rel).replace("/", "__")
        for suffix in (".gz", ".csv", ".skeleton", ".trc", ".txt"):
            name = name.removesuffix(suffix)
        try:
            result = analyze_file(path, cfg, out / name)
            row = {"file": str(rel), "status": "ok"}
            row.update({k: v for k, v in result.summary().items() if k not in ("source", "gaps_left")})
            row["gaps_left"] = len(result.quality["gaps_left"])
        except (ValueError, FileNotFoundError) as exc:  # bad file: report it, keep going
            row = {"file": str(rel), "status": f"error: {exc}"}
        rows.append(row)
    keys = list(dict.fromkeys(k for row in rows for k in row))
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "summary.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    ok = sum(r["status"] == "ok" for r in rows)
    print(f"[lfd] {ok}/{len(rows)} files analysed; summary: {out / 'summary.csv'}")
    print(f"[lfd] outputs in {out}")
    return out


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="analyze_arm")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    run(cfg, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
