"""Stage 4 — sweeps over crank angle x speed x case: point distribution over MPI ranks, mode
tracking, rank-aware logging."""
