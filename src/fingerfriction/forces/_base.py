"""What every force-file reader shares: the error they raise, the size bound of a channel,
and how a file's array becomes a channel of samples (:mod:`fingerfriction.forces.readers`
and :mod:`fingerfriction.forces.containers`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["ForceFileError", "MAX_SAMPLES"]

#: The most samples a channel may hold: about 83 min at 10 kHz, 400 MB per channel in
#: float64. A file announcing more is refused before its data are read.
MAX_SAMPLES = 50_000_000


class ForceFileError(ValueError):
    """A force file that cannot be read as the manifest describes it."""


def as_channel(values, *, name, path: Path) -> np.ndarray:
    """A force channel read from ``path`` as a float64 vector, checked: real numbers, not empty,
    one vector (squeezed), at most :data:`MAX_SAMPLES` values; :class:`ForceFileError` naming
    the channel and the file otherwise."""
    arr = np.asarray(values)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise ForceFileError(f"channel {name!r} in {str(path)!r} has dtype {arr.dtype}, expected numbers")
    if np.iscomplexobj(arr):
        raise ForceFileError(f"channel {name!r} in {str(path)!r} is complex, expected real numbers")
    if arr.size > MAX_SAMPLES:
        raise ForceFileError(f"channel {name!r} of {str(path)!r} holds {arr.size} values, more than the "
                             f"{MAX_SAMPLES} a trial may have (MAX_SAMPLES)")
    if arr.size == 0:
        raise ForceFileError(f"channel {name!r} in {str(path)!r} is empty (shape {arr.shape}): no samples")
    squeezed = np.squeeze(arr)
    if squeezed.ndim != 1:
        raise ForceFileError(
            f"channel {name!r} in {str(path)!r} has shape {arr.shape}, expected one vector of samples"
        )
    return squeezed.astype(np.float64)


def not_index(path: Path, fmt: str, wanted: dict) -> None:
    """Refuse channels given as column indices (``wanted``: channel key -> name or index) for a
    ``fmt`` file whose channels have names (:class:`ForceFileError`)."""
    for key, name in wanted.items():
        if isinstance(name, int):
            raise ForceFileError(
                f"channel {key} is given as column index {name}, but {str(path)!r} is a {fmt} file "
                "whose channels have names; give the name"
            )


def too_long(path: Path, name: str, key: str, n: int) -> ForceFileError:
    """The :class:`ForceFileError` of a channel with more than :data:`MAX_SAMPLES` samples."""
    return ForceFileError(
        f"channel {name!r} (channel {key}) of {str(path)!r} holds {n} samples, more than the "
        f"{MAX_SAMPLES} a trial may have (MAX_SAMPLES: {MAX_SAMPLES / 1e4 / 60:.0f} min at 10 kHz); "
        "split the recording into trials"
    )
