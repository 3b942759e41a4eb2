"""Progress of a streamed run: a tqdm bar on a terminal, plain periodic lines otherwise."""

from __future__ import annotations

import time

__all__ = ["progress_bar"]


def progress_bar(total: float, done: float, unit: str, enabled, stream):
    if not enabled:
        return None
    if enabled == "auto":
        enabled = hasattr(stream, "isatty") and stream.isatty()
        if not enabled:
            return _PlainProgress(total, done, unit, stream)
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit=unit, unit_scale=True, file=stream, smoothing=0.1, dynamic_ncols=True)


class _PlainProgress:
    """Periodic plain lines when not on a terminal (logs, CI)."""

    def __init__(self, total: float, done: float, unit: str, stream, every: float = 10.0):
        self.total, self.n, self.unit, self.stream, self.every = total, done, unit, stream, every
        self.start, self.start_n, self.last = time.monotonic(), done, 0.0

    def update(self, k: float) -> None:
        self.n += k
        now = time.monotonic()
        if now - self.last >= self.every or self.n >= self.total:
            self.last = now
            rate = (self.n - self.start_n) / max(now - self.start, 1e-9)
            eta = (self.total - self.n) / rate if rate > 0 else float("inf")
            print(
                f"{self.unit} {self.n:.6g}/{self.total:.6g} ({100 * self.n / self.total:.1f}%), "
                f"{rate:.3g} {'steps' if self.unit == 'step' else 'time units'}/s, ETA {eta:.0f} s",
                file=self.stream,
                flush=True,
            )

    def close(self) -> None:
        pass
