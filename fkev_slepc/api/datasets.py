"""Any group of an archive as an xarray Dataset, verified first: ``fkev_slepc.open_dataset``.

``xarray.open_dataset(path, group=...)`` reads the stored values as they are: a value changed
since the run finished comes back without a word. :func:`open_dataset` runs the check every
reader of the package runs before it decodes (:func:`fkev_slepc.archive.verified.checked`, as
``fk.open``, ``read_floquet``, ``read_response`` and ``open_design``): a damaged archive warns
(:class:`~fkev_slepc.archive.verified.DamagedArchiveWarning`), one whose metadata cannot be
decoded or that a live run is still writing is refused (:class:`~fkev_slepc.archive.verified.ArchiveError`),
then reads the group with xarray's h5netcdf engine (docs/archive.md, "Reading a group with xarray").
"""

from __future__ import annotations

from fkev_slepc.archive.products import FORMAT
from fkev_slepc.archive.verified import ArchiveError, checked


def open_dataset(path, group: str | None = None, **kwargs):
    """The group ``group`` of archive ``path`` (None: the root, the sweep) as an
    ``xarray.Dataset``, loaded into memory after the archive is verified.

    Parameters
    ----------
    path : str or Path
        An fkev archive (``fkev run``, ``floquet``, ``response --speeds -o``, ``design``).
    group : str, optional
        ``"floquet"``, ``"response"``, ``"design"``, ``"errors"``, ``"mesh"``, ``"tracking"``, ...
    **kwargs
        Passed to ``xarray.open_dataset`` (the engine is h5netcdf).

    Warns
    -----
    DamagedArchiveWarning
        The archive changed since its run finished (``fkev verify`` says where).

    Raises
    ------
    ArchiveError
        No such file or group, not an fkev archive (a single-point file of ``fkev response -o`` or
        ``fkev loads -o`` carries no checksums), metadata HDF5 cannot decode, or a run still writing it.
    """
    import h5py
    import xarray as xr

    path = checked(path, stacklevel=2)
    name = (group or "/").strip("/")
    with h5py.File(path, "r") as f:
        fmt = f.attrs.get("format", "")
        fmt = fmt.decode() if isinstance(fmt, bytes) else str(fmt)
        if fmt != FORMAT:  # as fk.open refuses it; a single-point file of fkev response/loads -o has no checksums
            raise ArchiveError(f"{path}: not an fkev archive (root attribute format={fmt!r}): nothing to verify it "
                               "against; a single-point file reads with xarray.open_dataset(path, engine='h5netcdf')")
        if name and not isinstance(f.get(name), h5py.Group):
            have = ", ".join(k for k in f if isinstance(f[k], h5py.Group))
            raise ArchiveError(f"{path}: no group {group!r} (its groups: {have or 'none'})")
    kwargs.setdefault("engine", "h5netcdf")
    with xr.open_dataset(path, group=name or None, **kwargs) as ds:
        return ds.load()
