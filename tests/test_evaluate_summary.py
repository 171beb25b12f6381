"""``evaluate.summary_lines``: the one line per policy kind that ``python evaluate.py`` prints, for
the reaching evaluator's metrics and for success-rate metrics (the Meta-World evaluator's)."""

from __future__ import annotations

from pathlib import Path

from evaluate import summary_lines

#: A Meta-World ``metrics.json`` entry as :class:`lfd.visuomotor.metaworld.MetaWorldEvaluator` writes it.
METAWORLD = {
    "success_rate": 0.84,
    "success_ci95": [0.7144, 0.9166],
    "episodes": 50,
    "successes": 42,
    "mean_time_to_success_s": 0.8125,
    "median_steps_to_success": 64.0,
    "latency_ms": 3.2,
    "checkpoint": "outputs/train/x/checkpoints/last.ckpt",
    "task": "push-v3",
    "split": "test",
    "horizon": 200,
    "colour_tta": False,
    "chunk_execution": None,
    "dmp_replan_every": None,
}
#: A reaching ``metrics.json`` entry (the keys the summary reads).
REACHING = {
    "final_distance_m": {"mean": 0.0178, "std": 0.01},
    "success_5cm": 0.9583,
    "approach_correct": 0.9583,
    "episodes": 24,
}


def test_success_rate_line():
    assert summary_lines({"cnn_dmp": METAWORLD}) == [
        "cnn_dmp: 42/50 successes (84 %, 95 % CI 71-92 %) on push-v3 test placements, 0.81 s to success"
    ]


def test_no_success_has_no_time_to_success():
    m = {
        **METAWORLD,
        "success_rate": 0.0,
        "successes": 0,
        "success_ci95": [0.0, 0.0714],
        "mean_time_to_success_s": None,
        "median_steps_to_success": None,
        "split": "val",
    }
    assert summary_lines({"velocity": m}) == [
        "velocity: 0/50 successes (0 %, 95 % CI 0-7 %) on push-v3 val placements"
    ]


def test_success_line_leaves_out_what_is_missing():
    assert summary_lines({"act": {"success_rate": 0.5, "episodes": 4}}) == ["act: 2/4 successes (50 %)"]


def test_reaching_line_is_unchanged():
    assert summary_lines({"cnn_dmp": REACHING, "velocity": {"final_distance_m": 0.1, "episodes": 24}}) == [
        "cnn_dmp: mean final distance 1.78 cm, success 96 %, correct approach 96 % (24 episodes)",
        "velocity: mean final distance 10.00 cm (24 episodes)",
    ]


def test_one_line_per_kind_in_order_and_other_entries_skipped():
    metrics = {"cnn_dmp": METAWORLD, "note": "text", "other": {"latency_ms": 1.0}, "diffusion": METAWORLD}
    lines = summary_lines(metrics)
    assert [line.split(":")[0] for line in lines] == ["cnn_dmp", "diffusion"]


def test_the_metaworld_evaluators_own_entry(tmp_path: Path):
    """The line reads the keys the Meta-World evaluator writes (its ``_summary``, no simulator)."""
    from lfd.visuomotor.metaworld.evaluator import EpisodeResult, MetaWorldEvaluator

    def result(i: int, steps: int | None) -> EpisodeResult:
        return EpisodeResult(
            "cnn_dmp", i, i, steps is not None, steps, None if steps is None else steps * 0.0125, [2.0], [0.0]
        )

    evaluator = MetaWorldEvaluator(task="push-v3", n_episodes=4)
    results = [result(0, 40), result(1, None), result(2, 80), result(3, 60)]
    entry = evaluator._summary("cnn_dmp", tmp_path / "last.ckpt", "push-v3", results)
    assert summary_lines({"cnn_dmp": entry}) == [
        "cnn_dmp: 3/4 successes (75 %, 95 % CI 30-95 %) on push-v3 test placements, 0.75 s to success"
    ]
