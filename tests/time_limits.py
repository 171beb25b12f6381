"""A wall-time bound for tests of bounded work (a helper module of the tests, not a test)."""

from __future__ import annotations

import contextlib
import signal


@contextlib.contextmanager
def deadline(seconds: float):
    """Within the block, raise ``TimeoutError`` after ``seconds`` s of wall time (SIGALRM, main thread):
    a test of a bound on work fails instead of hanging when the protection under test is switched off."""

    def _raise(*_):
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
