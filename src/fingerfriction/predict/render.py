"""Render a predicted relief on a flat friction-modulating display (surface haptics).

A surface haptic display (electroadhesion or ultrasonic friction reduction) is flat: it
can only change the friction coefficient under the finger. To make a finger sliding on it
feel the lateral force ``F_T(x)`` that a relief would produce (:mod:`fingerfriction.predict`),
the display must command, at each finger position ``x``, a friction coefficient
``mu_cmd(x)``.

Model of the display
--------------------
On flat ground ``dh/dx = 0`` and ``alpha = 0``, so Eq. (4) of Janko et al. 2018 reduces
to its interfacial part with ``sin alpha = 0``, ``cos alpha = 1``, and the deformation
term vanishes::

    F_flat = sum_i int_{C_i} (p0 + p1 * 0) (0 + mu * 1) dx = mu * p0 * L_flat(F_N)

where ``L_flat(F_N)`` is the total length of the finger's contact on flat ground at
normal force ``F_N`` (the forward model's geometric contact, the same definition the
prediction uses). A display that sets the friction coefficient to ``mu_cmd`` therefore
produces ``F = mu_cmd * N_eff`` with ``N_eff = p0 * L_flat(F_N)``, the model's normal
force on flat ground, and the command that reproduces the relief's force is::

    mu_cmd(x) = F_T(x) / (p0 * L_flat(F_N))

With the default parameters (``p0 = F_N / L_flat``, see :func:`~fingerfriction.predict.default_params`)
``N_eff = F_N`` and this is Amontons' ``mu_cmd = F_T / F_N``. The display is assumed to
set ``mu`` instantly and uniformly under the whole contact; a real display's bandwidth
and its attainable range ``[mu_min, mu_max]`` limit what it can render: commands outside
``mu_range`` are clipped with a warning (a negative ``F_T`` cannot be rendered by
friction at all). Fitted parameters need not satisfy ``p0 L_flat = F_N`` (the fit sees
drift-corrected forces); the command is then exact for the fitted model of the display,
and a warning says that it departs from Amontons' ``mu_cmd F_N``.

Queries
-------
:meth:`HapticRenderer.query` answers one position in pure Python from a uniform table
(index arithmetic and a linear interpolation, no NumPy call): for a scalar, NumPy's
per-call overhead (``np.interp`` on a scalar: about 1 us here) is larger than the whole
lookup (0.36 us; ``benchmarks/render.py`` prints both). :meth:`HapticRenderer.query_many` does
the same arithmetic vectorised for batches.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.io import wavfile

from .._atomic import atomic_write
from .forward import DEFAULT_LOAD_N, FORWARD_STEP_MM, flat_contact_length
from .prediction import Prediction, predict

__all__ = ["DisplayModel", "HapticRenderer", "read_command"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DisplayModel:
    """A flat friction-modulating display, as seen through Eq. (4) on flat ground.

    Parameters
    ----------
    normal_force : float
        Normal force ``F_N`` of the finger on the display, in N.
    p0 : float
        Eq. (4) pressure parameter in N/mm (times the effective width D).
    flat_length : float
        Contact length ``L_flat(F_N)`` of the finger on the flat display, in mm.
    mu_min, mu_max : float
        Friction coefficients the display can produce (default 0 and 5).
    """

    normal_force: float
    p0: float
    flat_length: float
    mu_min: float = 0.0
    mu_max: float = 5.0

    def __post_init__(self) -> None:
        for name in ("normal_force", "p0", "flat_length", "mu_min", "mu_max"):
            v = getattr(self, name)
            num = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
            if not num or not math.isfinite(v):
                raise ValueError(f"DisplayModel.{name} must be a finite number, got {v!r}")
            object.__setattr__(self, name, float(v))
        for name in ("normal_force", "p0", "flat_length"):
            if getattr(self, name) <= 0:
                raise ValueError(f"DisplayModel.{name} must be > 0, got {getattr(self, name)!r}")
        if not 0.0 <= self.mu_min < self.mu_max:
            raise ValueError(
                f"DisplayModel needs 0 <= mu_min < mu_max, got mu_min={self.mu_min!r}, mu_max={self.mu_max!r}"
            )

    @property
    def effective_normal_force(self) -> float:
        """``N_eff = p0 * L_flat`` in N: lateral force per unit of commanded mu."""
        return self.p0 * self.flat_length

    def lateral_force(self, mu_cmd):
        """Lateral force in N the display produces for a command ``mu_cmd`` (any shape)."""
        return np.asarray(mu_cmd, dtype=float) * self.effective_normal_force


class HapticRenderer:
    """Precomputed lateral force and friction command of a relief for one subject.

    Parameters
    ----------
    prediction : Prediction
        A predicted sweep (:func:`fingerfriction.predict.predict`).
    display : DisplayModel, optional
        The display. By default: normal force = the prediction's load, ``p0`` from the
        prediction's parameters and ``L_flat`` from the forward contact model
        (:func:`~fingerfriction.predict.flat_contact_length`).
    resolution : float, optional
        Spacing of the uniform position table in mm (default 0.01 mm).

    Attributes
    ----------
    x0 : float
        First table position in mm; positions below it answer the first value, above the
        last table position the last value (the finger is on flat ground there).
    dx : float
        Table spacing in mm.
    x, force, mu_cmd : (n,) ndarray
        Table positions (mm), lateral force F_T (N) and friction command.
    n_clipped : int
        Table entries whose command was clipped to the display's range.
    """

    def __init__(self, prediction: Prediction, display: DisplayModel | None = None, *,
                 resolution: float = 0.01):
        if not isinstance(prediction, Prediction):
            raise TypeError(f"prediction must be a Prediction, got {type(prediction).__name__}")
        if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive table spacing in mm, got {resolution!r}")
        if display is None:
            if prediction.finger is None:
                raise ValueError(
                    "the prediction carries no finger to compute the flat contact length; give a DisplayModel"
                )
            L = flat_contact_length(prediction.finger, load=prediction.load)
            display = DisplayModel(normal_force=prediction.load, p0=prediction.display_p0(prediction.load, L),
                                   flat_length=L)
        if not isinstance(display, DisplayModel):
            raise TypeError(f"display must be a DisplayModel, got {type(display).__name__}")
        self.prediction = prediction
        self.display = display
        ratio = display.effective_normal_force / display.normal_force
        if not 0.8 <= ratio <= 1.25:
            # Fitted p0 need not satisfy p0 L_flat = F_N (the fit sees drift-corrected forces);
            # the command is still exact for the model, but the display is then assumed to
            # follow the fitted Eq. (4), not Amontons' law at F_N.
            log.warning(
                "p0 * L_flat = %.3g N differs from the display's normal force %.3g N: mu_cmd assumes the "
                "display's lateral force is mu_cmd * p0 * L_flat (Eq. 4 on flat ground), not mu_cmd * F_N",
                display.effective_normal_force, display.normal_force,
            )
        xp = prediction.positions
        n = int(math.floor((xp[-1] - xp[0]) / resolution + 1e-9)) + 1
        if n < 2:
            raise ValueError("the prediction spans less than one table step; use a finer resolution")
        self.x0 = float(xp[0])
        self.dx = float(resolution)
        self.x = self.x0 + self.dx * np.arange(n)
        self.force = np.interp(self.x, xp, prediction.F_T)
        raw = self.force / display.effective_normal_force
        self.mu_cmd = np.clip(raw, display.mu_min, display.mu_max)
        self.n_clipped = int(np.count_nonzero(raw != self.mu_cmd))
        if self.n_clipped:
            log.warning(
                "%d of %d table entries of mu_cmd (range %.3g..%.3g) are outside the display's range "
                "[%g, %g] and were clipped: the display cannot render those forces",
                self.n_clipped, n, raw.min(), raw.max(), display.mu_min, display.mu_max,
            )
        # Pure-Python copies for the scalar path: list indexing of floats is ~10x cheaper than
        # indexing a NumPy array from Python.
        self._inv_dx = 1.0 / self.dx
        self._tmax = float(n - 1)
        self._mu_list = self.mu_cmd.tolist() + [float(self.mu_cmd[-1])]
        self._f_list = self.force.tolist() + [float(self.force[-1])]

    @classmethod
    def for_surface(cls, surface_spec, subject, params=None, *, load: float = DEFAULT_LOAD_N,
                    normal_force: float | None = None, step: float = FORWARD_STEP_MM,
                    resolution: float = 0.01,
                    mu_range: tuple[float | None, float | None] | None = None, model: str | None = None,
                    finger=None) -> HapticRenderer:
        """Predict a relief for a subject and precompute its renderer.

        Parameters
        ----------
        surface_spec, subject, params, load, step, model, finger
            As :func:`fingerfriction.predict.predict`.
        normal_force : float, optional
            Normal force on the display in N (default: ``load``).
        resolution : float, optional
            Table spacing in mm.
        mu_range : (float, float), optional
            The display's attainable friction coefficients; None (or an end None) is
            :class:`DisplayModel`'s default (0 and 5).
        """
        pred = predict(surface_spec, subject, params, load=load, step=step, model=model, finger=finger)
        fn = load if normal_force is None else float(normal_force)
        L = flat_contact_length(pred.finger, load=fn)
        ends = zip(("mu_min", "mu_max"), mu_range or (None, None), strict=True)
        mu = {k: v for k, v in ends if v is not None}
        disp = DisplayModel(normal_force=fn, p0=pred.display_p0(fn, L), flat_length=L, **mu)
        return cls(pred, disp, resolution=resolution)

    # ------------------------------------------------------------------ queries
    def query(self, x: float) -> float:
        """Friction command ``mu_cmd`` at finger position ``x`` (mm), linear interpolation.

        Outside the table the end values are held (flat ground). O(1), pure Python.
        """
        t = (x - self.x0) * self._inv_dx
        if t <= 0.0:
            return self._mu_list[0]
        if t >= self._tmax:
            return self._mu_list[-1]
        i = int(t)
        v = self._mu_list
        a = v[i]
        return a + (v[i + 1] - a) * (t - i)

    def query_force(self, x: float) -> float:
        """Target lateral force ``F_T`` (N) at finger position ``x`` (mm)."""
        # query's lookup, written out again on purpose: a shared helper's extra call would
        # slow the per-tick query by about a third (benchmarks/render.py, "unpaced")
        t = (x - self.x0) * self._inv_dx
        if t <= 0.0:
            return self._f_list[0]
        if t >= self._tmax:
            return self._f_list[-1]
        i = int(t)
        v = self._f_list
        a = v[i]
        return a + (v[i + 1] - a) * (t - i)

    def query_many(self, x, *, out: np.ndarray | None = None) -> np.ndarray:
        """Friction command at many positions (mm), any shape; same rule as :meth:`query`."""
        return self._lookup_many(x, self.mu_cmd, out)

    def query_force_many(self, x) -> np.ndarray:
        """Target lateral force F_T (N) at many positions (mm)."""
        return self._lookup_many(x, self.force, None)

    def _lookup_many(self, x, table: np.ndarray, out):
        x = np.asarray(x, dtype=float)
        t = (x - self.x0) * self._inv_dx
        if np.isnan(t.sum()):  # one pass; NaN would become a garbage index below
            i = int(np.flatnonzero(np.isnan(t.ravel()))[0])
            raise ValueError(f"positions must be finite (mm); got {float(x.ravel()[i])!r} at flat index {i}")
        np.clip(t, 0.0, self._tmax, out=t)
        i = t.astype(np.intp)
        np.minimum(i, table.size - 2, out=i)
        t -= i
        a = table[i]
        res = np.multiply(table[i + 1] - a, t, out=out)
        res += a
        return res

    # ------------------------------------------------------------------ export
    def table_frame(self):
        """The table as a pandas DataFrame: x_mm, F_T_N, mu_cmd."""
        return pd.DataFrame({"x_mm": self.x, "F_T_N": self.force, "mu_cmd": self.mu_cmd})

    def write_table(self, path: str | os.PathLike) -> str:
        """Write the table as CSV (x_mm, F_T_N, mu_cmd), atomically. Returns the path."""
        p = os.fspath(path)
        atomic_write(p, lambda tmp: self.table_frame().to_csv(tmp, index=False, float_format="%.9g"))
        return p

    def command_signal(self, speed: float, rate: float, *, x_start: float | None = None,
                       x_end: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The friction command as a signal in time for a finger sliding at constant speed.

        Parameters
        ----------
        speed : float
            Sliding speed in mm/s (> 0; left to right).
        rate : float
            Display update rate in Hz (> 0).
        x_start, x_end : float, optional
            Finger positions in mm at the first and last sample (default: the table's).

        Returns
        -------
        t : (m,) ndarray
            Time in s, ``k / rate``.
        x : (m,) ndarray
            Finger position in mm, ``x_start + speed * t``.
        mu_cmd : (m,) ndarray
            Friction command.
        """
        for name, v in (("speed", speed), ("rate", rate)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                unit = "mm/s" if name == "speed" else "Hz"
                raise ValueError(f"{name} must be a positive number ({unit}), got {v!r}")
        a = self.x0 if x_start is None else float(x_start)
        b = float(self.x[-1]) if x_end is None else float(x_end)
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise ValueError(f"x_start < x_end (mm) required, got {a!r}, {b!r}")
        m = int(math.floor((b - a) / speed * rate + 1e-9)) + 1
        if m < 2:
            raise ValueError(
                f"speed {speed} mm/s and rate {rate} Hz give fewer than 2 samples over [{a}, {b}] mm"
            )
        if speed / rate > 10 * self.dx:
            log.warning("a step of %.3g mm per sample (speed/rate) is coarse for a %.3g mm table",
                        speed / rate, self.dx)
        t = np.arange(m) / rate
        x = a + speed * t
        return t, x, self.query_many(x)

    def write_command(self, path: str | os.PathLike, speed: float = 80.0, rate: float = 2000.0, *,
                      x_start: float | None = None, x_end: float | None = None) -> dict[str, str]:
        """Export the command signal as WAV (``.wav``) or CSV (``.csv``), atomically.

        * WAV: mono 32-bit float samples at ``rate`` Hz, each sample the commanded friction
          coefficient itself (not rescaled). A sidecar ``<path>.json`` records the speed,
          rate, start position, display model, surface and subject needed to map sample
          ``k`` back to position ``x_start + speed * k / rate``.
        * CSV: columns ``t_s, x_mm, mu_cmd`` (and the same sidecar).

        Parameters
        ----------
        path : path-like
            The signal file, ``.wav`` or ``.csv``.
        speed : float
            Sliding speed in mm/s (default 80 mm/s, the middle of the paper's three speeds).
        rate : float
            Display update rate in Hz (default 2 kHz; an integer for a WAV file).
        x_start, x_end : float, optional
            As in :meth:`command_signal`.

        Returns
        -------
        dict
            ``{'signal': path, 'meta': sidecar path}``.
        """
        p = os.fspath(path)
        ext = os.path.splitext(p)[1].lower()
        if ext not in (".wav", ".csv"):
            raise ValueError(f"command file {p!r} must end in .wav or .csv")
        t, x, mu = self.command_signal(speed, rate, x_start=x_start, x_end=x_end)
        if ext == ".wav":
            if rate != int(rate):
                raise ValueError(f"a WAV file needs an integer sample rate in Hz, got {rate!r}")
            data = mu.astype(np.float32)
            atomic_write(p, lambda tmp: wavfile.write(tmp, int(rate), data))
        else:
            df = pd.DataFrame({"t_s": t, "x_mm": x, "mu_cmd": mu})
            atomic_write(p, lambda tmp: df.to_csv(tmp, index=False, float_format="%.9g"))
        pred = self.prediction
        meta = {
            "format": "fingerfriction-haptic-command",
            "signal": os.path.basename(p),
            "quantity": "mu_cmd (friction coefficient, dimensionless)",
            "speed_mm_s": float(speed),
            "rate_hz": float(rate),
            "x_start_mm": float(x[0]),
            "n_samples": int(x.size),
            "position_of_sample": "x_start_mm + speed_mm_s * k / rate_hz",
            "display": {
                "normal_force_N": self.display.normal_force,
                "p0_N_per_mm": self.display.p0,
                "flat_length_mm": self.display.flat_length,
                "effective_normal_force_N": self.display.effective_normal_force,
                "mu_range": [self.display.mu_min, self.display.mu_max],
                "lateral_force": "mu_cmd * p0 * flat_length (Eq. 4 on flat ground)",
            },
            "surface": pred.surface.name,
            "subject": str(pred.subject),
            "model": pred.model,
            "params": dataclasses.asdict(pred.params),
            "n_clipped_table_entries": self.n_clipped,
        }
        mp = p + ".json"

        def wjson(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(meta, fh, indent=2)

        atomic_write(mp, wjson)
        return {"signal": p, "meta": mp}


def read_command(path: str | os.PathLike) -> tuple[np.ndarray, dict]:
    """Read an exported command signal (WAV or CSV) and its JSON sidecar.

    Returns
    -------
    mu_cmd : (m,) ndarray
        The command samples.
    meta : dict
        The sidecar (speed, rate, start position, display model).
    """
    p = os.fspath(path)
    try:
        with open(p + ".json", encoding="utf-8") as fh:
            meta = json.load(fh)
    except OSError as exc:
        raise ValueError(f"{p}.json: cannot read the command's sidecar ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{p}.json: not valid JSON ({exc})") from None
    if p.lower().endswith(".wav"):
        try:
            rate, data = wavfile.read(p)
        except (OSError, ValueError) as exc:
            raise ValueError(f"{p}: cannot read WAV ({exc})") from None
        if rate != int(meta.get("rate_hz", -1)):
            raise ValueError(f"{p}: WAV rate {rate} Hz differs from the sidecar's {meta.get('rate_hz')!r}")
        return np.asarray(data, dtype=float), meta
    try:
        df = pd.read_csv(p)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{p}: cannot read CSV ({exc})") from None
    if "mu_cmd" not in df:
        raise ValueError(f"{p}: no 'mu_cmd' column (columns: {list(df.columns)})")
    return df["mu_cmd"].to_numpy(dtype=float), meta
