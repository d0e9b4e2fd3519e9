"""The measured video-force offset of one trial (:class:`OffsetEstimate`), what
:func:`~fingerfriction.selfcheck.sync.estimate_offsets` returns per trial."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["OffsetEstimate"]


@dataclass(frozen=True)
class OffsetEstimate:
    """The measured video-force offset of one trial.

    Attributes
    ----------
    trial_id : str
    offset_s : float
        What to add to the force clock (``force.t0_s``) to put it on the video clock, s.
    se_s : float
        Its standard error, s.
    relative_s : float
        The part that differs from the trial's finger's other trials, s (``offset_s`` minus
        ``common_s``).
    common_s, common_se_s : float
        The offset shared by the finger's trials and its standard error, s (NaN when not
        measured).
    method : str
        ``'relative'`` (against the other trials of the finger), ``'prior'`` (one trial
        alone: the pre-sliding distance's prior range sets the error) or ``'none'``.
    n_reference : int
        Trials of the finger the estimate rests on.
    message : str
        What was done, or why nothing could be.
    level_by : str
        What fixed the offset the finger's trials share: ``'touch-down'`` (the touch-downs,
        :mod:`.touchdown`), ``'starts'`` (the starts of the slides alone: their differences
        in acceleration, or the pre-sliding prior) or ``''``.
    """

    trial_id: str
    offset_s: float
    se_s: float
    relative_s: float = math.nan
    common_s: float = math.nan
    common_se_s: float = math.nan
    method: str = "relative"
    n_reference: int = 0
    message: str = ""
    level_by: str = ""

    @property
    def measured(self) -> bool:
        return math.isfinite(self.offset_s)

    def to_dict(self) -> dict:
        def ms(v):
            return None if not math.isfinite(v) else round(1e3 * float(v), 4)

        return {
            "offset_ms": ms(self.offset_s),
            "se_ms": ms(self.se_s),
            "relative_ms": ms(self.relative_s),
            "common_ms": ms(self.common_s),
            "common_se_ms": ms(self.common_se_s),
            "method": self.method,
            "n_reference": self.n_reference,
            "message": self.message,
            "level_by": self.level_by,
        }
