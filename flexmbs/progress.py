"""A dependency-free progress bar on stderr."""

from __future__ import annotations

import sys
import time


class ProgressBar:
    """Fraction done, simulated time, elapsed and remaining wall time.

    Redraws at most ten times a second on a terminal; when stderr is not a
    terminal it prints only the final line.
    """

    def __init__(self, label: str, stream=None, width: int = 30):
        self.label, self.width = label, width
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self.last = 0.0

    def __call__(self, fraction: float, t: float) -> None:
        now = time.perf_counter()
        if fraction < 1.0 and (not self.tty or now - self.last < 0.1):
            return
        self.last = now
        elapsed = now - self.start
        eta = elapsed * (1.0 - fraction) / fraction if fraction > 0 else float("nan")
        filled = int(self.width * fraction)
        line = (f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * fraction:5.1f}%  "
                f"t = {t:.4g}  elapsed {elapsed:.1f} s  eta {eta:.1f} s")
        if self.tty:
            self.stream.write("\r" + line + ("\n" if fraction >= 1.0 else ""))
        elif fraction >= 1.0:
            self.stream.write(line + "\n")
        self.stream.flush()
