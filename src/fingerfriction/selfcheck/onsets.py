"""The start of one trial's slide in both recordings (:func:`onset_data`): x(t) from the
video and F_T/F_N from the force sensor around the moment the finger starts to move, on one
time grid. What the synchronisation (:func:`fingerfriction.selfcheck.sync.estimate_offsets`)
fits; the reasoning is in that module's notes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OnsetData", "onset_data", "MOTION_MM", "WINDOW_S", "MARGIN_S", "RATE_HZ"]

#: Displacement in mm that marks the start of motion in the video (well above the noise of
#: x(t), well below the pre-sliding distance of any finger).
MOTION_MM = 0.5
#: Window around the start of motion, in s of video time: before, after.
WINDOW_S = (0.05, 0.06)
#: Margin in s of force data kept beyond the window on each side (offsets up to this are
#: measured).
MARGIN_S = 0.1
#: Rate of the force data used, Hz.
RATE_HZ = 2000.0


@dataclass(frozen=True)
class OnsetData:
    """The start of one trial's slide in both recordings (what :func:`estimate_offsets` needs).

    Attributes
    ----------
    trial_id, group : str
        The trial and its finger (subject): trials of a group share the pre-sliding law.
    t_video : (m,) ndarray
        Video frame times in s (the manifest's clock), frames with a finger position.
    d_video : (m,) ndarray
        The finger's displacement from its rest in mm along its sliding direction.
    t_motion : float
        Video time in s at which the displacement passes :data:`MOTION_MM`.
    s0, ds : float
        Force clock time in s of ``ratio[0]``, and the sample spacing in s.
    ratio : (k,) ndarray
        F_T / F_N, signed by the sliding direction; NaN where the finger does not press.
    frame_period : float
        Video frame period in s.
    touch_video_s, touch_video_se_s : float
        The touch-down in the video (video clock, s) and its standard error
        (:func:`~fingerfriction.selfcheck.touchdown.touch_video`; NaN: not measured).
    touch_force_s, touch_force_se_s : float
        The touch-down in the force record (the manifest's force clock, s) and its standard
        error (:func:`~fingerfriction.selfcheck.touchdown.touch_force`; NaN: not measured).
    """

    trial_id: str
    group: str
    t_video: np.ndarray
    d_video: np.ndarray
    t_motion: float
    s0: float
    ds: float
    ratio: np.ndarray
    frame_period: float
    touch_video_s: float = math.nan
    touch_video_se_s: float = math.nan
    touch_force_s: float = math.nan
    touch_force_se_s: float = math.nan

    @property
    def s(self) -> np.ndarray:
        return self.s0 + self.ds * np.arange(self.ratio.size)

    @property
    def touch_offset_s(self) -> float:
        """The offset the touch-downs give (what to add to the force clock), s (NaN: not
        measured in both recordings)."""
        return self.touch_video_s - self.touch_force_s

    @property
    def touch_se_s(self) -> float:
        """Its standard error, s."""
        return math.hypot(self.touch_video_se_s, self.touch_force_se_s)

    def shifted(self, offset_s: float, rate: float = 1.0) -> OnsetData:
        """The same data with the force clock moved by ``offset_s`` (and scaled by ``rate``
        about ``s0``): what a corrected ``force.t0_s`` (``fs_hz``) gives."""
        return OnsetData(
            self.trial_id,
            self.group,
            self.t_video,
            self.d_video,
            self.t_motion,
            self.s0 + offset_s,
            self.ds * rate,
            self.ratio,
            self.frame_period,
            self.touch_video_s,
            self.touch_video_se_s,
            self.s0 + offset_s + (self.touch_force_s - self.s0) * rate,
            self.touch_force_se_s * rate,
        )

    def to_dict(self) -> dict:
        return {
            "trial_id": self.trial_id,
            "group": self.group,
            "t_motion": self.t_motion,
            "t_video": [round(float(v), 7) for v in self.t_video],
            "d_video": [round(float(v), 5) for v in self.d_video],
            "s0": self.s0,
            "ds": self.ds,
            "frame_period": self.frame_period,
            "ratio": [None if not np.isfinite(v) else round(float(v), 5) for v in self.ratio],
            "touch": {
                k: None if not math.isfinite(v) else round(float(v), 8)
                for k, v in (
                    ("video_s", self.touch_video_s),
                    ("video_se_s", self.touch_video_se_s),
                    ("force_s", self.touch_force_s),
                    ("force_se_s", self.touch_force_se_s),
                )
            },
        }

    @classmethod
    def from_dict(cls, d: dict) -> OnsetData:
        touch = d.get("touch") or {}

        def tv(key: str) -> float:
            v = touch.get(key)
            return math.nan if v is None else float(v)

        return cls(
            str(d["trial_id"]),
            str(d["group"]),
            np.asarray(d["t_video"], float),
            np.asarray(d["d_video"], float),
            float(d["t_motion"]),
            float(d["s0"]),
            float(d["ds"]),
            np.array([np.nan if v is None else v for v in d["ratio"]], float),
            float(d["frame_period"]),
            tv("video_s"),
            tv("video_se_s"),
            tv("force_s"),
            tv("force_se_s"),
        )


def onset_data(
    trial_id: str, group: str, t_frames, x_frames, f_n, f_t, fs_hz: float, t0_s: float
) -> OnsetData | str:
    """Extract the start of a trial's slide from its x(t) and its forces.

    Parameters
    ----------
    trial_id, group : str
    t_frames, x_frames : (n_frames,) array_like
        Frame times (s, the manifest's video clock) and finger positions (mm, NaN unknown).
    f_n, f_t : (n,) array_like
        Normal and tangential force in N on the force clock (after the sensor's steps).
    fs_hz, t0_s : float
        The force clock as the manifest states it: sample ``k`` at ``t0_s + k / fs_hz``.

    Returns
    -------
    OnsetData, or a str saying why the start cannot be seen (the video starts with the
    finger already sliding, the finger never presses...).
    """
    t = np.asarray(t_frames, float)
    x = np.asarray(x_frames, float)
    ok = np.isfinite(x)
    if ok.sum() < 20:
        return "fewer than 20 frames with a finger position"
    tv, xv = t[ok], x[ok]
    direction = 1.0 if xv[-1] >= xv[0] else -1.0
    rest = direction * (xv - xv[0])
    moved = np.flatnonzero(rest > MOTION_MM)
    if moved.size == 0:
        return f"the finger never moves {MOTION_MM:g} mm from its first position"
    k_motion = int(moved[0])
    t_motion = float(tv[k_motion])
    before = tv < t_motion - 0.03
    if before.sum() < 5:
        return (
            "the video has no rest of the finger before it slides (fewer than 5 tracked frames "
            "30 ms before it moves): the start of the slide is not seen"
        )
    x_rest = float(np.median(xv[before][-min(int(before.sum()), 20) :]))
    d = direction * (xv - x_rest)
    lo, hi = t_motion - WINDOW_S[0] - MARGIN_S, t_motion + WINDOW_S[1] + MARGIN_S
    keep = (tv >= lo - 0.05) & (tv <= hi + 0.05)
    fn = np.asarray(f_n, float)
    ft = np.asarray(f_t, float)
    step = max(int(round(fs_hz / RATE_HZ)), 1)
    n = (fn.size // step) * step
    if n < 2 * step:
        return "the force record is too short"
    fn_b = fn[:n].reshape(-1, step).mean(axis=1)
    ft_b = ft[:n].reshape(-1, step).mean(axis=1)
    ds = step / fs_hz
    s = t0_s + (np.arange(fn_b.size) + 0.5 * (step - 1) / step) * ds
    level = float(np.nanpercentile(fn_b, 95))
    if not level > 0:
        return "the finger never presses (F_N never positive)"
    pressing = _longest_run(fn_b > 0.1 * level)  # the press, not a drift that crosses the level
    ratio = np.where(pressing, direction * ft_b / np.where(pressing, fn_b, 1.0), np.nan)
    sel = (s >= lo) & (s <= hi)
    if sel.sum() < 20:
        return "the force record does not cover the start of the slide (check force.t0_s and fs_hz)"
    i0 = int(np.flatnonzero(sel)[0])
    period = float(np.median(np.diff(t))) if t.size > 1 else math.nan
    return OnsetData(
        trial_id, str(group), tv[keep], d[keep], t_motion, float(s[i0]), ds, ratio[sel].astype(float), period
    )


def _longest_run(mask: np.ndarray) -> np.ndarray:
    """``mask`` with only its longest run of True kept."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    out = np.zeros(mask.shape, bool)
    if starts.size:
        k = int(np.argmax(ends - starts))
        out[starts[k] : ends[k]] = True
    return out
