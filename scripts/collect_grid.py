"""Tables and the data-efficiency plot of a policy grid, from its multirun folder.

    python train.py -m experiment=quick +grid=policies [hydra/launcher=joblib]
    python train.py -m experiment=metaworld +grid=mt10 [hydra/launcher=joblib]
    python scripts/collect_grid.py outputs/train/multirun/<date> [--out DIR] [--metric success_5cm]

Prints the Markdown table (mean ± std over seeds per task, policy and training-set size) and writes
``grid.md``, ``grid.json`` (one row per job) and ``data_efficiency.png`` into ``--out`` (the
multirun folder by default). Unfinished jobs are counted, not hidden.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lfd.io.files import write_json_atomic, write_text_atomic
from lfd.visuomotor.eval.grid import collect, markdown_table, plot_data_efficiency, summarise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sweep_dir", type=Path, help="the multirun folder (hydra.sweep.dir)")
    parser.add_argument("--out", type=Path, default=None, help="where to write (default: sweep_dir)")
    parser.add_argument(
        "--metric",
        default=None,
        help="the plotted metric, a grid.json key (default: success_rate for Meta-World, success_5cm for reaching)",
    )
    args = parser.parse_args(argv)
    try:
        rows = collect(args.sweep_dir)
    except (FileNotFoundError, ValueError) as e:
        print(f"collect_grid: {e}", file=sys.stderr)
        return 2
    out = args.out or args.sweep_dir
    summaries = summarise(rows)
    table = markdown_table(summaries)
    print(table)
    write_text_atomic(out / "grid.md", table)
    write_json_atomic(out / "grid.json", {"jobs": rows, "summary": summaries})
    plot = plot_data_efficiency(summaries, out / "data_efficiency.png", args.metric)
    print(f"[lfd] wrote {out / 'grid.md'}, {out / 'grid.json'} and {plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
