"""Stage 5 — the HDF5 archive: schema and life cycle (``store``), point writing (``writer``),
reading back into :class:`~fkev_slepc.archive.reader.SweepResults` (``reader``)."""
