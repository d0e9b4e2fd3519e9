"""What the consistency stage finds: one :class:`Check` per test, with its level and the
figure it measured, and the stage's thresholds (:class:`SelfCheckParams`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from .._check import check_option
from ..flags import Flag

__all__ = [
    "LEVELS",
    "SYNC_MODES",
    "Check",
    "SelfCheckParams",
    "SelfCheckError",
    "first_error",
    "describe_checks",
]

#: Levels of a check, most serious first: an ``error`` fails the trial (nothing of it
#: reaches the fit), a ``warning`` keeps it and is reported, ``info`` is recorded only.
LEVELS = ("error", "warning", "info")

#: ``analyze --sync``: ``check`` (the default) measures the video-force offset and fails a
#: trial whose manifest offset is off; ``auto`` uses the measured offset; ``manifest``
#: trusts the manifest (the offset is not measured).
SYNC_MODES = ("check", "auto", "manifest")


class SelfCheckError(ValueError):
    """A trial whose recordings contradict each other or their manifest entry (an error-level
    :class:`Check`); the message is the check's one-line reason."""


@dataclass(frozen=True)
class Check:
    """One consistency test of a trial and what it found.

    Attributes
    ----------
    code : str
        The test's name (``'force-level'``, ``'channel-polarity'``, ``'sync-offset'``...).
    level : str
        ``'error'``, ``'warning'`` or ``'info'`` (:data:`LEVELS`); ``'ok'`` for a test that
        passed.
    figure : float
        The measured figure the test compares with its threshold (NaN when not measured).
    unit : str
        Unit of ``figure`` (``'N'``, ``'deg'``, ``'ms'``, ``'%'``, ``''``...).
    message : str
        One line: what was measured, what was expected and, for a finding, the likely
        cause and the manifest field to look at.
    field : str
        The manifest field most likely wrong (``'force.units'``, ``'force.channels'``...),
        '' when none.
    """

    code: str
    level: str
    figure: float
    unit: str
    message: str
    field: str = ""

    def __post_init__(self) -> None:
        check_option("Check.level", self.level, (*LEVELS, "ok"))

    @property
    def finding(self) -> bool:
        """An error or a warning."""
        return self.level in ("error", "warning")

    def line(self) -> str:
        """``'code: message'``."""
        return f"{self.code}: {self.message}"

    def to_flag(self) -> Flag:
        """The finding as the package's :class:`~fingerfriction.flags.Flag`, level kept
        (stored with the force stage's flags of the trial)."""
        if not self.finding and self.level != "info":
            raise ValueError(f"check {self.code!r} passed ('ok'): it is not a flag")
        return Flag(self.level, self.code, self.message)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["figure"] = None if not math.isfinite(self.figure) else float(self.figure)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Check:
        fig = d.get("figure")
        return cls(
            code=str(d["code"]),
            level=str(d["level"]),
            figure=math.nan if fig is None else float(fig),
            unit=str(d.get("unit", "")),
            message=str(d.get("message", "")),
            field=str(d.get("field", "")),
        )


def first_error(checks) -> Check | None:
    """The first error-level check, or None."""
    return next((c for c in checks if c.level == "error"), None)


def describe_checks(checks) -> list[str]:
    """One line per check that found something: ``'error sync-offset: ...'``."""
    return [f"{c.level} {c.line()}" for c in checks if c.finding]


@dataclass(frozen=True)
class SelfCheckParams:
    """The consistency stage's mode and thresholds (``docs/selfcheck.md`` says how each was
    chosen and the false-flag rate measured with it).

    Parameters
    ----------
    sync : {'check', 'auto', 'manifest'}
        :data:`SYNC_MODES`.
    f_n_range_n : (float, float)
        Plausible normal force of a finger in N while it presses (``force-level``).
    loading_angle_deg : float
        Largest angle of the force while the finger presses before it slides, measured
        from the +F_N axis in the (F_N, F_T) plane (``channel-polarity``, ``channel-gain``).
    flat_ratio_range : (float, float)
        Physical range of flat-ground F_T / F_N while sliding (``flat-friction``).
    sync_frames : float
        ``sync-offset`` fires when the offset is above ``max(sync_frames / fps, 3 SE)``.
    sync_se_floor_s : float
        Smallest standard error in s given to a measured offset.
    rate_tolerance : float
        Relative disagreement of the force clock with the mains above which
        ``rate-mismatch`` fires (and the disagreement is also beyond 3 SE).
    mains_hz : (float, ...)
        Nominal mains frequencies in Hz looked for in the force record.
    aspect_tolerance : float
        Relative disagreement of the feature's width / height (manifest against the
        calibration frame) above which ``surface-geometry`` fires.
    speed_ratio : float
        Measured / nominal sliding speed outside ``[1 / speed_ratio, speed_ratio]`` gives
        the ``speed`` warning (a scale or surface-size mistake).
    moved_frames : float
        With ``sync='auto'``, a trial whose force clock moved by more than this many frame
        periods gets a warning (the clocks disagree).
    """

    sync: str = "check"
    f_n_range_n: tuple = (0.02, 20.0)
    loading_angle_deg: float = 25.0
    flat_ratio_range: tuple = (0.05, 3.0)
    sync_frames: float = 2.0
    sync_se_floor_s: float = 1e-4
    rate_tolerance: float = 0.005
    mains_hz: tuple = (50.0, 60.0)
    aspect_tolerance: float = 0.2
    speed_ratio: float = 1.5
    moved_frames: float = 3.0

    def __post_init__(self) -> None:
        check_option("sync", self.sync, SYNC_MODES)
        for name in ("f_n_range_n", "flat_ratio_range"):
            lo, hi = (float(v) for v in getattr(self, name))
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
                raise ValueError(
                    f"SelfCheckParams.{name} must be (low, high) with 0 < low < high, "
                    f"got {getattr(self, name)!r}"
                )
            object.__setattr__(self, name, (lo, hi))
        for name in (
            "loading_angle_deg",
            "sync_frames",
            "sync_se_floor_s",
            "rate_tolerance",
            "aspect_tolerance",
            "speed_ratio",
            "moved_frames",
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"SelfCheckParams.{name} must be a positive number, got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.speed_ratio <= 1:
            raise ValueError(f"SelfCheckParams.speed_ratio must be > 1, got {self.speed_ratio!r}")
        mains = tuple(float(f) for f in self.mains_hz)
        if not mains or any(not (math.isfinite(f) and f > 0) for f in mains):
            raise ValueError(
                f"SelfCheckParams.mains_hz must be positive frequencies in Hz, got {self.mains_hz!r}"
            )
        object.__setattr__(self, "mains_hz", mains)

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("f_n_range_n", "flat_ratio_range", "mains_hz"):
            d[k] = list(d[k])
        return d

    @classmethod
    def from_mapping(cls, opts) -> SelfCheckParams:
        """From keyword options (ValueError naming an unknown one)."""
        opts = dict(opts or {})
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(opts) - known)
        if unknown:
            raise ValueError(f"selfcheck option(s) {unknown} unknown; allowed: {', '.join(sorted(known))}")
        return cls(**opts)
