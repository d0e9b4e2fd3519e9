"""Readers of the container formats that hold force channels beside other things: MATLAB
(v4 and v5 through :func:`scipy.io.loadmat`, v7.3 through h5py), HDF5 and National
Instruments TDMS (npTDMS). Each returns ``({key: array}, info)`` for the wanted
``{key: name}`` (:mod:`fingerfriction.forces.readers` dispatches to them).

What the software that writes these files does, and what is refused with a one-line
:class:`~fingerfriction.forces.readers.ForceFileError`:

* MATLAB empty arrays (v7.3: a dataset of the dimensions with ``MATLAB_empty``) and sparse
  matrices (v7.3: a group of ``data``, ``ir``, ``jc`` with ``MATLAB_sparse``; v5: what
  scipy returns as ``scipy.sparse``) are named as such; a sparse matrix's parts are not
  channels;
* an HDF5 file (MATLAB v7.3 included) any of whose data lives in another file (an
  external link, a virtual dataset, external raw storage) is refused before anything is
  followed: a force file holds its own data, the data that resume hashes and that stays
  inside the study folder;
* TDMS channels are found by their own names: LabVIEW's default group names are dates
  (``07/09/2012 06:58:23 PM - ...``) holding ``/``; a bare name in several groups is
  ambiguous, and said to be. npTDMS is given the open data file, so a ``<file>_index``
  beside it (another file, possibly stale) is never read.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ._base import MAX_SAMPLES, ForceFileError, as_channel, not_index, too_long

__all__ = ["hdf5_outside_data", "read_mat", "read_hdf5", "read_tdms"]


def _split_name(name: str) -> list[str]:
    return [p for p in name.replace(".", "/").split("/") if p]


def _mat_leaves(node, prefix: str = "", other: dict | None = None) -> list[str]:
    """Dotted paths of the numeric arrays in a loadmat(simplify_cells=True) dict; ``other``
    collects the variables that are not channels (sparse, empty) with what they are."""
    import scipy.sparse  # loadmat returns MATLAB sparse matrices as scipy.sparse

    out: list[str] = []
    for k, v in node.items():
        if k.startswith("__"):
            continue
        path = f"{prefix}{k}"
        if isinstance(v, dict):
            out.extend(_mat_leaves(v, path + ".", other))
        elif scipy.sparse.issparse(v):
            if other is not None:
                other[path] = f"a MATLAB sparse matrix ({v.shape[0]} x {v.shape[1]})"
        elif isinstance(v, np.ndarray | int | float) and np.asarray(v).dtype.kind in "fiub":
            if np.asarray(v).size == 0:
                if other is not None:
                    other[path] = f"an empty MATLAB array ({' x '.join(map(str, np.shape(v)))})"
            else:
                out.append(path)
    return sorted(out)


#: How to store a channel that MATLAB wrote in a form that is not a vector of samples.
_MAT_HINT = "a channel must be a numeric vector of samples (in MATLAB: a full, non-empty double array)"


def _not_a_channel(name: str, key: str, path: Path, what: str, version: str = "") -> ForceFileError:
    return ForceFileError(f"variable {name!r} (channel {key}) in MATLAB{version} file {str(path)!r} is "
                          f"{what}; {_MAT_HINT}")


def read_mat(path: Path, wanted: dict, delimiter=None) -> tuple[dict, dict]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    not_index(path, "mat", wanted)
    if h5py.is_hdf5(path):  # MATLAB v7.3 files are HDF5 with a 512-byte user block
        return _read_mat73(path, wanted)
    import scipy.io  # only for MATLAB v5 files
    import scipy.sparse  # loadmat returns MATLAB sparse matrices as scipy.sparse

    try:  # every variable is loaded: their sizes first, from the headers alone
        sizes = {n: math.prod(shape) for n, shape, _cls in scipy.io.whosmat(path)}
    except Exception as exc:  # noqa: BLE001 - a damaged file raises many types (zlib.error...)
        raise ForceFileError(f"cannot read {str(path)!r} as a MATLAB v5 file "
                             f"({type(exc).__name__}: {exc})") from None
    big = {n: k for n, k in sizes.items() if k > MAX_SAMPLES}
    if big:
        n, k = next(iter(big.items()))
        raise ForceFileError(f"variable {n!r} of MATLAB file {str(path)!r} holds {k} values, more than the "
                             f"{MAX_SAMPLES} a trial's channel may have (MAX_SAMPLES); save the trial's "
                             "channels alone in a file of their own")
    try:
        # simplify_cells turns structs into dicts; MATLAB objects (classdef) are not
        # unpickled by scipy, they come back as opaque MatlabOpaque arrays we refuse.
        data = scipy.io.loadmat(path, simplify_cells=True)
    except NotImplementedError as exc:  # e.g. an HDF5 file that h5py did not recognise
        raise ForceFileError(f"cannot read {str(path)!r} as a MATLAB file: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - a damaged file raises many types (zlib.error...)
        raise ForceFileError(f"cannot read {str(path)!r} as a MATLAB v5 file "
                             f"({type(exc).__name__}: {exc})") from None
    other: dict[str, str] = {}
    names = _mat_leaves(data, other=other)
    out = {}
    for key, name in wanted.items():
        node = data
        for part in _split_name(name):
            if not isinstance(node, dict) or part not in node:
                raise ForceFileError(
                    f"no variable {name!r} (channel {key}) in {str(path)!r}; numeric variables "
                    f"(struct fields as 'a.b'): {names[:30]}"
                )
            node = node[part]
        dotted = ".".join(_split_name(name))
        if dotted in other:
            raise _not_a_channel(name, key, path, other[dotted])
        if scipy.sparse.issparse(node):  # e.g. inside a cell
            raise _not_a_channel(name, key, path, "a MATLAB sparse matrix")
        out[key] = as_channel(node, name=name, path=path)
    return out, {"names": names}


def _mat_class(obj) -> str:
    cls = obj.attrs.get("MATLAB_class", b"double")
    return cls.decode() if isinstance(cls, bytes) else str(cls)


def _mat73_variables(f) -> tuple[list[str], dict[str, str]]:
    """The numeric variables of a MATLAB v7.3 file (struct fields as ``a.b``), and what the
    other variables are: sparse matrices (a group of ``data``, ``ir``, ``jc`` with a
    ``MATLAB_sparse`` attribute), empty arrays (a dataset of their dimensions with a
    ``MATLAB_empty`` attribute), cells, text, function handles."""
    import h5py  # only for HDF5 and MATLAB v7.3 files

    names: list[str] = []
    other: dict[str, str] = {}
    sparse: list[str] = []

    def visit(name: str, obj) -> None:
        if name.split("/")[0].startswith("#"):  # '#refs#', '#subsystem#': MATLAB's internals
            return
        dotted = name.replace("/", ".")
        if any(dotted.startswith(s + ".") for s in sparse):  # data, ir, jc of a sparse matrix
            return
        if isinstance(obj, h5py.Group):
            if "MATLAB_sparse" in obj.attrs:
                sparse.append(dotted)
                other[dotted] = (f"a MATLAB sparse matrix ({int(np.asarray(obj.attrs['MATLAB_sparse']))} "
                                 "rows)")
            return
        if not isinstance(obj, h5py.Dataset):
            return
        cls = _mat_class(obj)
        if np.asarray(obj.attrs.get("MATLAB_empty", 0)).any():
            other[dotted] = f"an empty MATLAB {cls} array (MATLAB_empty)"
        elif cls in ("cell", "struct", "char", "function_handle") or obj.dtype.kind not in "fiub":
            other[dotted] = f"a MATLAB {cls} (dtype {obj.dtype})"
        else:
            names.append(dotted)

    f.visititems(visit)
    return sorted(names), other


def _read_mat73(path: Path, wanted: dict) -> tuple[dict, dict]:
    out = {}
    with _open_hdf5(path, "MATLAB v7.3") as f:
        names, other = _mat73_variables(f)
        for key, name in wanted.items():
            dotted = ".".join(_split_name(name))
            if dotted in other:
                raise _not_a_channel(name, key, path, other[dotted], " v7.3")
            whole = next((v for v in other if dotted.startswith(v + ".")), None)
            if whole is not None:
                raise _not_a_channel(name, key, path, f"part of the variable {whole!r}, {other[whole]}",
                                     " v7.3")
            if dotted not in names:
                raise ForceFileError(
                    f"no variable {name!r} (channel {key}) in MATLAB v7.3 file {str(path)!r}; "
                    f"numeric variables (struct fields as 'a.b'): {names[:30]}"
                )
            # MATLAB stores column-major, so an n x 1 column vector appears as (1, n) here;
            # squeezing makes row and column vectors alike.
            obj = f[dotted.replace(".", "/")]
            if obj.size > MAX_SAMPLES:
                raise too_long(path, name, key, obj.size)
            out[key] = as_channel(obj[()], name=name, path=path)
    return out, {"names": names}


def _dataset_names(f) -> list[str]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    found: list[str] = []
    f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) else None)
    return found


def hdf5_outside_data(f) -> str | None:
    """What in an open HDF5 file (MATLAB v7.3 included) takes its data from another file,
    or None: an external link, a virtual dataset, a dataset with external raw storage.

    Nothing is followed: links are listed without being traversed and a dataset's storage
    is read from its creation properties, so no other file is opened here.
    """
    import h5py  # only for HDF5 and MATLAB v7.3 files

    found: list[str] = []

    def link(name: str, lnk) -> bool | None:
        if isinstance(lnk, h5py.ExternalLink):
            found.append(f"{name!r} is an external link to {lnk.path!r} in {lnk.filename!r}")
            return True
        return None

    def dataset(name: str, obj) -> bool | None:
        if isinstance(obj, h5py.Dataset):
            if obj.is_virtual:
                files = sorted({s.file_name for s in obj.virtual_sources()})
                found.append(f"dataset {name!r} is a virtual dataset mapped from {files}")
                return True
            if obj.external:
                found.append(f"dataset {name!r} keeps its data in external file(s) "
                             f"{[str(e[0]) for e in obj.external]}")
                return True
        return None

    f.visititems_links(link)
    if not found:
        f.visititems(dataset)
    return found[0] if found else None


class _open_hdf5:
    """``h5py.File`` opened read-only, refused (ForceFileError) when any of its data comes
    from another file: a force file must hold its own data, since that is what resume
    hashes and what stays inside the study folder."""

    def __init__(self, path: Path, what: str = "HDF5"):
        import h5py  # only for HDF5 and MATLAB v7.3 files

        try:
            self.f = h5py.File(path, "r")
        except OSError as exc:
            raise ForceFileError(f"cannot read {str(path)!r} as {what}: {exc}") from None
        try:
            outside = hdf5_outside_data(self.f)
        except (OSError, RuntimeError, KeyError, ValueError) as exc:  # a damaged file
            self.f.close()
            raise ForceFileError(f"cannot read {str(path)!r} as {what}: {exc}") from None
        if outside is not None:
            self.f.close()
            raise ForceFileError(
                f"{str(path)!r} takes data from another file ({outside}); a force file must hold its own "
                "data: copy it in (h5repack, or save the variables again in MATLAB)"
            )

    def __enter__(self):
        return self.f

    def __exit__(self, *exc) -> None:
        self.f.close()


def read_hdf5(path: Path, wanted: dict, delimiter=None) -> tuple[dict, dict]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    not_index(path, "hdf5", wanted)
    info: dict = {}
    with _open_hdf5(path) as f:
        info["names"] = _dataset_names(f)
        out = {}
        for key, name in wanted.items():
            obj = f.get(name)
            if not isinstance(obj, h5py.Dataset):
                raise ForceFileError(
                    f"no dataset {name!r} (channel {key}) in {str(path)!r}; datasets: {info['names'][:30]}"
                )
            if obj.size > MAX_SAMPLES:
                raise too_long(path, name, key, obj.size)
            out[key] = as_channel(obj[()], name=name, path=path)
            for attr in ("fs_hz", "sampling_rate_hz"):
                if attr in obj.attrs and key != "time":
                    info.setdefault("fs_hz", float(np.asarray(obj.attrs[attr])))
    return out, info


def _tdms_lookup(groups: list, name: str, key: str, path: Path):
    """The channel ``name`` of a TDMS file: a ``group/channel`` path, or a channel's bare
    name when only one group holds it. Group names may themselves hold ``/`` (LabVIEW's
    default groups are dates, ``07/09/2012 06:58:23 PM - ...``), so each channel's own
    name is compared, never a split of the path."""
    hits = [(g.name, c) for g in groups for c in g.channels()
            if f"{g.name}/{c.name}" == name or c.name == name]
    if len(hits) == 1:
        return hits[0][1]
    if not hits:
        paths = sorted(f"{g.name}/{c.name}" for g in groups for c in g.channels())
        raise ForceFileError(
            f"no channel named {name!r} (channel {key}) in {str(path)!r}; use 'group/channel', "
            f"one of {paths[:30]}"
        )
    raise ForceFileError(
        f"channel name {name!r} (channel {key}) is ambiguous in {str(path)!r}: {len(hits)} channels "
        f"answer to it, in groups {sorted({g for g, _ in hits})[:10]}; give 'group/channel'"
    )


def read_tdms(path: Path, wanted: dict, delimiter=None) -> tuple[dict, dict]:
    from nptdms import TdmsFile  # only for TDMS files

    not_index(path, "tdms", wanted)
    try:
        # Opened here and passed as a file: given a path, npTDMS also reads a
        # '<file>_index' beside it, a second file whose content resume does not hash
        # (stale, or a link out of the study folder); the data file alone says everything.
        with open(path, "rb") as fh:
            # metadata only when no channel is wanted (probing the names)
            tdms = TdmsFile.read(fh) if wanted else TdmsFile.read_metadata(fh)
    except Exception as exc:  # noqa: BLE001 - a damaged file raises many types
        raise ForceFileError(f"cannot read {str(path)!r} as a TDMS file ({type(exc).__name__}: {exc})") \
            from None
    groups = list(tdms.groups())
    info: dict = {"names": sorted(f"{g.name}/{c.name}" for g in groups for c in g.channels()),
                  "leaves": sorted({c.name for g in groups for c in g.channels()})}
    out = {}
    for key, name in wanted.items():
        ch = _tdms_lookup(groups, name, key, path)
        out[key] = as_channel(ch[:], name=name, path=path)
        inc = ch.properties.get("wf_increment")
        if key != "time" and inc is not None and float(inc) > 0:
            info.setdefault("fs_hz", 1.0 / float(inc))
        start = ch.properties.get("wf_start_offset")
        if key == "F1" and start is not None and math.isfinite(float(start)):
            info["time0_s"] = float(start)  # the waveform's time of sample 0, in s
    return out, info
