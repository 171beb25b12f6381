"""The fuzz harness's targets and its sandboxed worker.

Each :class:`Target` names one input format, how to find a valid sample of it in a folder written by
:func:`lfd.samples.write_samples` (or in the test fixtures), and the public reader that consumes it. The
harness (``test_fuzz_inputs.py``) mutates the sample's bytes with hypothesis and hands each mutated file
to a :class:`Sandbox`: a separate process with an address-space limit, whose every run must end, within
a time bound, either in success or in one clear line (a ``ValueError`` or ``OSError`` whose message is
one line naming the file). A traceback of any other exception, a run past the time bound (a hang) or a
dead worker (memory, a crash) is a finding.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import resource
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

#: bytes of address space the worker may add to what it holds after its imports
MEMORY_HEADROOM = 3 * 1024**3
#: the longest one run may take, s (a parse of a small file takes well under a second; two busy cores)
RUN_TIMEOUT_S = 30.0
#: the longest an accepted message may be, characters
MAX_MESSAGE = 600


# ---------------------------------------------------------------------------- consumers (run in the worker)
def _skeleton(path: Path) -> None:
    from lfd.human.analysis import analyze_arm
    from lfd.human.readers.dispatch import read_skeleton

    analyze_arm(read_skeleton(path))


def _robot(source_type: str) -> Callable[[Path], None]:
    def consume(path: Path) -> None:
        from lfd.imitation.sources import load_robot_source
        from lfd.robots import load_robot

        load_robot_source(path, source_type, load_robot("wam4"))

    return consume


def _scenario(path: Path) -> None:
    from lfd.visuomotor.eval.scenario import load_scenario

    load_scenario(path)


def _teach_scene(path: Path) -> None:
    from lfd.teach import TeachSession

    with TeachSession(robot="wam4", scene=path):
        pass


def _dmp_json(path: Path) -> None:
    from lfd.dmp import DMP

    DMP.load(path).rollout()


def _lerobot(path: Path) -> None:
    from lfd.interop.lerobot.reader import LeRobotFolder

    folder = LeRobotFolder(path)
    for _key, column in folder.data.items():
        _ = column[: min(len(column), 4)] if hasattr(column, "__len__") else column


def _checkpoint(path: Path) -> None:
    from lfd.visuomotor.policies.factory import load_policy

    load_policy(path)


@dataclass(frozen=True)
class Target:
    """One input format: ``sample`` is the valid file (or folder) relative to the samples folder;
    ``mutable`` the files inside a folder sample that get mutated (empty: the sample itself);
    ``consume`` the reader's public entry."""

    name: str
    sample: str
    consume: Callable[[Path], None]
    mutable: tuple[str, ...] = ()


TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target("skeleton_csv", "recording.csv", _skeleton),
        Target("kinect_csv", "kimore.csv", _skeleton),
        Target("ntu_skeleton", "ntu.skeleton", _skeleton),
        Target("trc", "synthetic.trc", _skeleton),
        Target("joint_csv", "arm.csv", _robot("joint_csv")),
        Target("ros1_bag", "arm.bag", _robot("bag")),
        Target(
            "teach_export",
            "teach_export",
            _robot("teach"),
            mutable=("demo.json", "demo.csv", "episode.npz", "demo.dmp.json"),
        ),
        Target("dmp_json", "teach_export/demo.dmp.json", _dmp_json),
        Target("scenario_yaml", "scenario.yaml", _scenario),
        Target("teach_scene_yaml", "teach_scene.yaml", _teach_scene),
        Target(
            "lerobot_dataset",
            "lerobot",
            _lerobot,
            mutable=(
                "meta/info.json",
                "meta/stats.json",
                "meta/tasks.parquet",
                "meta/episodes/chunk-000/file-000.parquet",
                "data/chunk-000/file-000.parquet",
            ),
        ),
        Target("checkpoint", "policy.ckpt", _checkpoint),
    )
}


# ---------------------------------------------------------------------------- the sandboxed worker
def _vm_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def _worker(conn, target: str) -> None:
    import lfd.human.analysis  # imported before the memory limit: they map more than they use
    import lfd.imitation.sources
    import lfd.interop.lerobot.reader
    import lfd.teach
    import lfd.visuomotor.eval.scenario
    import lfd.visuomotor.policies.factory  # noqa: F401

    limit = _vm_bytes() + MEMORY_HEADROOM
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    consume = TARGETS[target].consume
    conn.send(("ready", ""))
    while True:
        path = conn.recv()
        if path is None:
            return
        try:
            consume(Path(path))
            conn.send(("ok", ""))
        except (ValueError, OSError) as e:
            conn.send(("refused", f"{type(e).__name__}: {e}"))
        except BaseException:  # every other exception is what the harness looks for
            conn.send(("crash", traceback.format_exc(limit=-6)))


class Sandbox:
    """A worker process for one target; :meth:`run` gives ``(outcome, message)`` with outcome one of
    ``ok``, ``refused``, ``crash`` (another exception; message: its traceback), ``hang`` (no answer
    within ``timeout``), ``died`` (the worker ended: memory, a signal). A hang or death restarts it."""

    def __init__(self, target: str, timeout: float = RUN_TIMEOUT_S) -> None:
        self.target, self.timeout = target, timeout
        self._ctx = mp.get_context("spawn")
        self._start()

    def _start(self) -> None:
        self._conn, child = self._ctx.Pipe()
        self._proc = self._ctx.Process(target=_worker, args=(child, self.target), daemon=True)
        self._proc.start()
        child.close()
        if not self._conn.poll(180.0):
            raise RuntimeError(f"fuzz worker for {self.target} did not start")
        self._conn.recv()

    def _restart(self) -> None:
        self._proc.kill()
        self._proc.join(10)
        self._start()

    def run(self, path: Path) -> tuple[str, str]:
        try:
            self._conn.send(str(path))
            if not self._conn.poll(self.timeout):
                self._restart()
                return "hang", f"no result within {self.timeout:.0f} s"
            return self._conn.recv()
        except (EOFError, BrokenPipeError, ConnectionResetError):
            code = self._proc.exitcode
            self._restart()
            return "died", f"worker exit code {code}"

    def close(self) -> None:
        with contextlib.suppress(BrokenPipeError, OSError):
            self._conn.send(None)
        self._proc.join(10)
        if self._proc.is_alive():
            self._proc.kill()
