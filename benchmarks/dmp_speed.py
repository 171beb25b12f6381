"""Speed and reproduction benchmark of lfd.dmp against movement-primitives 0.9.1 and pydmps 0.2.

All libraries run in this one process on the same 7-DoF demonstrations (T = 100 and 1000
samples over 2 s, K = 20 and 50 basis functions). Measured per configuration:

- fit: learn one demonstration. For lfd the first fit on a new time grid also builds the
  grid's rollout operator ("cold"); later fits on the same grid reuse it ("warm").
- 1 rollout: reproduce the demonstration once.
- 1000 rollouts: 1000 different weight sets (e.g. PoWER exploration). lfd evaluates them in
  one batched call; the reference libraries loop in Python, timed over a subset and
  extrapolated (the output says so).
- reproduction error: RMSE and end-point error relative to the largest per-DoF range.

Then 1000 rollouts against this machine's limits measured in the same process, with 1 and 2
torch threads: the write bandwidth (filling a warm buffer) and the float64 GEMM throughput (a
1024^3 product); a batch of rollouts is one GEMM writing ``B T D`` floats, so its lower bound
is the larger of the two times, and the table prints which applies and the fraction reached.

Plus ``DMPLayer`` forward + backward for B = 256, T = 100, D = 7, K = 20 (median of many
runs). Timings are wall-clock medians with torch's default thread count; the load average
is printed because co-tenant processes on a small machine distort them (with OpenMP's
default busy-waiting, torch's worker threads then stall even tiny operations; exporting
``OMP_WAIT_POLICY=PASSIVE`` avoids that).

Usage::

    PYTHONPATH=src python benchmarks/dmp_speed.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
import torch

from lfd.dmp import DMP, DMPLayer
from lfd.dmp.functional import clear_caches

N_DIMS, DURATION, BATCH = 7, 2.0, 1000


def demonstration(n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The same smooth 7-DoF joint trajectory (radians) sampled at ``n_steps`` points over 2 s."""
    rng = np.random.default_rng(0)
    start, stroke = rng.uniform(-1, 1, N_DIMS), rng.uniform(-1, 1, N_DIMS)
    frequency, bump = rng.integers(1, 4, N_DIMS), rng.uniform(0.1, 0.4, N_DIMS)
    t = np.linspace(0.0, DURATION, n_steps)
    s = t / DURATION
    min_jerk = 10 * s**3 - 15 * s**4 + 6 * s**5
    return t, start + np.outer(min_jerk, stroke) + bump * np.sin(np.pi * np.outer(s, frequency)) * np.sin(
        np.pi * s
    )[:, None]


def median_time(function, repeats: int) -> float:
    """Median wall-clock seconds of ``function()`` over ``repeats`` calls (after one warm-up)."""
    function()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def errors(out: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(RMSE, end-point error) relative to the largest per-DoF range of ``y``."""
    n = min(len(out), len(y))
    scale = np.ptp(y, axis=0).max()
    rmse = np.sqrt(np.mean(np.sum((out[:n] - y[:n]) ** 2, axis=-1)))
    return rmse / scale, np.linalg.norm(out[n - 1] - y[n - 1]) / scale


def bench_lfd(t, y, n_basis, weights, repeats):
    def fit_cold():
        clear_caches()
        DMP(n_basis).fit(t, y)

    cold = median_time(fit_cold, repeats)
    warm = median_time(lambda: DMP(n_basis).fit(t, y), repeats)
    dmp = DMP(n_basis).fit(t, y)
    one = median_time(dmp.rollout, repeats)
    many = median_time(lambda: dmp.rollout(weights=weights), max(3, repeats // 4))
    return {
        "fit": warm,
        "fit_cold": cold,
        "one": one,
        "many": many,
        "many_note": "batched",
        "errors": errors(dmp.rollout(), y),
    }


def bench_movement_primitives(t, y, n_basis, weights, repeats, n_loop):
    from movement_primitives.dmp import DMP as MPDMP

    def fit():
        dmp = MPDMP(n_dims=N_DIMS, execution_time=DURATION, dt=t[1] - t[0], n_weights_per_dim=n_basis)
        dmp.imitate(t, y)
        dmp.configure(start_y=y[0], goal_y=y[-1])
        return dmp

    fit_time = median_time(fit, repeats)
    dmp = fit()
    reproduction = errors(dmp.open_loop()[1], y)
    one = median_time(dmp.open_loop, max(1, repeats // 4))

    def loop():
        for w in weights[:n_loop]:
            dmp.forcing_term.weights_[:] = w
            dmp.open_loop()

    many = median_time(loop, 1) * BATCH / n_loop
    return {
        "fit": fit_time,
        "one": one,
        "many": many,
        "many_note": f"loop, extrapolated from {n_loop}",
        "errors": reproduction,
    }


def bench_pydmps(t, y, n_basis, weights, repeats, n_loop):
    from pydmps.dmp_discrete import DMPs_discrete

    def fit():
        # pydmps runs on its own clock (1 s, tau scales it): dt = 1 / T gives T steps.
        dmp = DMPs_discrete(n_dmps=N_DIMS, n_bfs=n_basis, dt=1.0 / len(t))
        dmp.imitate_path(y_des=y.T.copy())
        return dmp

    fit_time = median_time(fit, max(1, repeats // 4))
    dmp = fit()
    # pydmps records the state *after* each step: sample i approximates the demo at i + 1.
    reproduction = errors(np.concatenate([y[:1], dmp.rollout()[0][:-1]]), y)
    one = median_time(dmp.rollout, max(1, repeats // 4))

    def loop():
        for w in weights[:n_loop]:
            dmp.w = w
            dmp.rollout()

    many = median_time(loop, 1) * BATCH / n_loop
    return {
        "fit": fit_time,
        "one": one,
        "many": many,
        "many_note": f"loop, extrapolated from {n_loop}",
        "errors": reproduction,
    }


def bench_layer(repeats: int, device: str) -> float:
    """Median seconds of forward + backward (a VJP with a fixed upstream gradient, no loss ops)."""
    layer = DMPLayer(n_basis=20, n_steps=100, dt=0.04).to(device)
    generator = torch.Generator().manual_seed(0)
    y0, goal = (torch.randn(256, N_DIMS, generator=generator).to(device).requires_grad_() for _ in range(2))
    weights = (10 * torch.randn(256, N_DIMS, 20, generator=generator)).to(device).requires_grad_()
    upstream = torch.randn(256, 100, N_DIMS, generator=generator).to(device)

    def step():
        layer(y0, goal, weights).backward(upstream)
        if device == "cuda":
            torch.cuda.synchronize()

    for _ in range(10):
        step()
    return median_time(step, repeats)


def machine_limits(repeats: int) -> tuple[float, float]:
    """This machine's write bandwidth (bytes/s: filling a warm 64 MB float64 buffer) and float64
    GEMM throughput (flop/s: 1024 x 1024 x 1024 into a warm output), at torch's current thread count."""
    buffer = torch.empty(8 << 20, dtype=torch.float64)
    fill = median_time(lambda: buffer.fill_(1.0), repeats)
    a, b = torch.randn(1024, 1024, dtype=torch.float64), torch.randn(1024, 1024, dtype=torch.float64)
    out = torch.empty(1024, 1024, dtype=torch.float64)
    gemm = median_time(lambda: torch.mm(a, b, out=out), repeats)
    return buffer.numel() * 8 / fill, 2 * 1024**3 / gemm


def roofline(repeats: int) -> list[str]:
    """1000 rollouts against the machine's limits, with 1 and 2 torch threads.

    A rollout batch writes ``B T D`` floats (``(B, T, D)`` float64 output) and is one GEMM of
    ``(B D, K + 2)`` inputs (start, goal, weights) by ``(K + 2, T)`` operator rows:
    ``2 B D (K + 2) T`` flops. Its lower bound is the larger of the write time at the measured
    bandwidth and the GEMM time at the measured throughput; the fraction is bound / measured.
    """
    lines = []
    default_threads = torch.get_num_threads()
    rng = np.random.default_rng(2)
    for threads in (1, 2):
        torch.set_num_threads(threads)
        lines.append(
            f"\n{threads} thread(s); limits measured just before and after each row, the higher kept "
            "(the least disturbed by other processes, so the fraction is not flattered):\n"
        )
        lines.append(
            "| T | K | 1000 rollouts [ms] | written [GB/s] | GEMM [GFLOP/s] | machine: write [GB/s], "
            "GEMM [GFLOP/s] | bound | bound [ms] | fraction |"
        )
        lines.append("|---|---|---|---|---|---|---|---|---|")
        for n_steps in (100, 1000):
            t, y = demonstration(n_steps)
            for n_basis in (20, 50):
                dmp = DMP(n_basis).fit(t, y)
                weights = dmp.weights_ + rng.normal(size=(BATCH, N_DIMS, n_basis))
                before = machine_limits(repeats)
                elapsed = median_time(lambda dmp=dmp, weights=weights: dmp.rollout(weights=weights), repeats)
                after = machine_limits(repeats)
                bandwidth, throughput = max(before[0], after[0]), max(before[1], after[1])
                written = BATCH * n_steps * N_DIMS * 8
                flops = 2 * BATCH * N_DIMS * (n_basis + 2) * n_steps
                bounds = {"memory": written / bandwidth, "GEMM": flops / throughput}
                kind = max(bounds, key=bounds.get)
                lines.append(
                    f"| {n_steps} | {n_basis} | {elapsed * 1e3:.2f} | {written / elapsed / 1e9:.2f} | "
                    f"{flops / elapsed / 1e9:.1f} | {bandwidth / 1e9:.1f}, {throughput / 1e9:.1f} | {kind} | "
                    f"{bounds[kind] * 1e3:.2f} | {bounds[kind] / elapsed:.2f} |"
                )
    torch.set_num_threads(default_threads)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="fewer repeats and shorter reference loops (< 1 min)"
    )
    args = parser.parse_args()
    repeats = 5 if args.quick else 21
    rng = np.random.default_rng(1)

    print(
        f"torch {torch.__version__}, {torch.get_num_threads()} intra-op threads (default), "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at start\n"
    )
    rows, ratios = [], []
    for n_steps in (100, 1000):
        t, y = demonstration(n_steps)
        for n_basis in (20, 50):
            fitted = DMP(n_basis).fit(t, y).weights_
            weights = fitted + rng.normal(size=(BATCH, N_DIMS, n_basis)) * fitted.std()
            n_loop = (3 if args.quick else 20) if n_steps == 1000 else (10 if args.quick else 100)
            results = {
                "lfd.dmp": bench_lfd(t, y, n_basis, weights, repeats),
                "movement-primitives 0.9.1": bench_movement_primitives(
                    t, y, n_basis, weights, repeats, n_loop
                ),
                "pydmps 0.2": bench_pydmps(t, y, n_basis, weights, repeats, n_loop),
            }
            for name, r in results.items():
                fit = f"{r['fit'] * 1e3:.2f}" + (
                    f" (cold {r['fit_cold'] * 1e3:.2f})" if "fit_cold" in r else ""
                )
                rows.append(
                    f"| {n_steps} | {n_basis} | {name} | {fit} | {r['one'] * 1e3:.2f} | "
                    f"{r['many'] * 1e3:.1f} ({r['many_note']}) | {r['errors'][0]:.2e} | {r['errors'][1]:.2e} |"
                )
            ours = results["lfd.dmp"]
            for name in ("movement-primitives 0.9.1", "pydmps 0.2"):
                other = results[name]
                ratios.append(
                    f"| {n_steps} | {n_basis} | {name} | {other['fit'] / ours['fit']:.0f}x "
                    f"(cold {other['fit'] / ours['fit_cold']:.1f}x) | {other['one'] / ours['one']:.0f}x | "
                    f"{other['many'] / ours['many']:.0f}x | {other['errors'][0] / ours['errors'][0]:.1f}x |"
                )

    print(
        "| T | K | library | fit [ms] | 1 rollout [ms] | 1000 rollouts [ms] | RMSE / range | end error / range |"
    )
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print("\nSpeed-up of lfd.dmp (their time / ours) and reproduction-error ratio (their RMSE / ours):\n")
    print("| T | K | vs | fit (warm, cold) | 1 rollout | 1000 rollouts | RMSE ratio |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(ratios))
    layer_repeats = 50 if args.quick else 300
    print(
        f"\nDMPLayer forward + backward, B=256, T=100, D=7, K=20, float32, CPU: "
        f"{bench_layer(layer_repeats, 'cpu') * 1e3:.2f} ms (median of {layer_repeats})"
    )
    if torch.cuda.is_available():
        print(
            f"DMPLayer forward + backward, same sizes, CUDA ({torch.cuda.get_device_name()}): "
            f"{bench_layer(layer_repeats, 'cuda') * 1e3:.2f} ms (median of {layer_repeats})"
        )
    print(
        "\n1000 rollouts against this machine's measured limits (fraction = lower bound / measured "
        "time; target >= 0.33, i.e. within 3x):"
    )
    print("\n".join(roofline(5 if args.quick else 15)))
    print(f"load average {os.getloadavg()[0]:.1f} at end")


if __name__ == "__main__":
    main()
