"""Progress of a long batch of jobs: a tqdm bar on a terminal, plain lines otherwise, or quiet."""

from __future__ import annotations

import sys
import time


class Progress:
    """A tqdm bar on a terminal; otherwise a plain line at every tenth of the jobs.

    Args:
        total: Jobs in all; done: already finished before this run.
        tty: Draw a bar (stderr is a terminal); quiet: print nothing.
        name: Prefix of the lines ("sweep").
    """

    def __init__(self, total: int, done: int, *, tty: bool, quiet: bool = False, name="jobs"):
        self.total, self.count, self.quiet, self.name = total, done, quiet, name
        self._next_log = done + max(1, total // 10)
        self._bar = None
        if tty and not quiet:
            from tqdm import tqdm

            self._bar = tqdm(total=total, initial=done, unit="trial", desc=name, file=sys.stderr)

    def say(self, line: str) -> None:
        """One line for the user (above the bar, if there is one)."""
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.write(line, file=sys.stderr)
        else:
            print(line, file=sys.stderr, flush=True)

    def update(self, text: str, extra: str = "") -> None:
        """One job ended; ``text`` says which and how; ``extra`` is appended to log lines."""
        self.count += 1
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)
            self._bar.update(1)
        elif not self.quiet and (self.count >= self._next_log or self.count == self.total):
            self.say(f"[{self.count}/{self.total}] {text}{extra}")
            self._next_log = self.count + max(1, self.total // 10)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


class RateSinceFirst:
    """A batch's rate of work [units/s] from its first finished job on, for "about N left".

    Counted from the command's start, it would take in the kernel's compile and the
    workers' start, which come before the first job ends and not again: after a cold
    compile the default sweep said "about 3 min left" with 45 s to go.
    """

    def __init__(self):
        self._first: tuple[float, float] | None = None  # (time, units done by then)
        self.done = 0.0

    def add(self, units: float) -> float | None:
        """``units`` more work finished now; the rate since the first job, None for the first."""
        self.done += units
        now = time.perf_counter()
        if self._first is None:
            self._first = (now, self.done)
            return None
        elapsed, units_since = now - self._first[0], self.done - self._first[1]
        return units_since / elapsed if elapsed > 0 and units_since > 0 else None
