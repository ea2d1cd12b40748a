"""Periodic analyses of the running linkage at constant crank speed (docs/theory.md §18): the one
periodic system (``system``: coefficients, generator, load, interpolant), its monodromy
(``magnus``), Floquet multipliers (``floquet``) and their reductions (``reduce``: frozen modes;
``components``: link-frame Craig–Bampton modes; ``truncation``: the measured convergence rule),
the unstable speed bands and the one verdict rule (``bands``), the one cycle mean (``cycle_mean``),
and the steady periodic response (``harmonic_balance``, ``shooting``, ``response``, ``steady``;
on link components with the static correction of the dropped modes: ``component_response``)
with its station outputs (``stations``, ``link_stress``).

Stage order (tests/test_layout.py): status < scene < model < solve < periodic < archive < sweep <
design < plots < api < cli. Nothing here imports the frozen-time engines' sweeps or archives.
"""
