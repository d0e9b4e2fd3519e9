"""Progress display on stderr (rich), shared by ``analyze``, ``fit``, ``report`` and the demo."""

from __future__ import annotations

from collections.abc import Callable

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

__all__ = ["ProgressBar", "stage_progress"]


class ProgressBar:
    """A rich progress bar on stderr, or nothing when ``enabled`` is False.

    Parameters
    ----------
    enabled : bool
        Show the bar.
    total : int
        Number of steps.
    description : str
        Shown left of the bar.
    """

    def __init__(self, enabled: bool, total: int, description: str):
        self._p = None
        if enabled:
            self._p = Progress(
                TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("{task.fields[note]}"), TimeElapsedColumn(), TimeRemainingColumn(),
                console=Console(stderr=True), transient=False,
            )
            self._p.start()
            self._task = self._p.add_task(description, total=total, note="")

    def advance(self, note: str = "") -> None:
        """One step done; ``note`` is shown beside the bar."""
        if self._p is not None:
            self._p.update(self._task, advance=1, note=note)

    def close(self) -> None:
        """Stop the display (the last state stays on screen)."""
        if self._p is not None:
            self._p.stop()


def stage_progress(enabled: bool, prefix: str) -> tuple[Callable | None, Callable[[], None]]:
    """A ``progress(stage, done, total, label)`` callback with one bar per stage, and its closer.

    For callers that report several stages one after the other
    (``simulate_study(progress=...)``): a new stage closes the previous bars. Returns
    ``(None, no-op)`` when ``enabled`` is False.
    """
    if not enabled:
        return None, lambda: None
    bars: dict[str, ProgressBar] = {}

    def cb(stage: str, done: int, total: int, label: str) -> None:
        if stage not in bars:
            for b in bars.values():
                b.close()
            bars[stage] = ProgressBar(True, total, f"{prefix} {stage}")
        bars[stage].advance(label)

    def close() -> None:
        for b in bars.values():
            b.close()

    return cb, close
