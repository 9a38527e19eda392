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
        self.start = None  # the clock starts at the first report, so that a bar made early times only its run
        self.last = 0.0
        self.open = False  # a partial line is on the terminal
        self.done = False

    def __call__(self, fraction: float, t: float) -> None:
        now = time.perf_counter()
        if self.start is None:
            self.start = now
        fraction = min(max(float(fraction), 0.0), 1.0)
        final = fraction >= 1.0
        if self.done or (not final and (not self.tty or now - self.last < 0.1)):
            return
        self.last = now
        elapsed = now - self.start
        eta = f"{elapsed * (1.0 - fraction) / fraction:.1f} s" if fraction > 0 else "--"
        filled = int(self.width * fraction)
        line = (f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * fraction:5.1f}%  "
                f"t = {t:.4g}  elapsed {elapsed:.1f} s  eta {eta}")
        if self.tty:
            self.stream.write("\r" + line + ("\n" if final else ""))
            self.open = not final
        else:
            self.stream.write(line + "\n")
        self.done = final
        self.stream.flush()

    def close(self) -> None:
        """End a partial terminal line (a run that stopped early), so that what follows starts cleanly."""
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False
