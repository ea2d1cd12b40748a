"""Stage 3 — eigen-solutions of M q'' + C q' + K q = 0: the QEP container, the dense (LAPACK) and
SLEPc engines with their PETSc plumbing, engine choice, and post-processing into modes."""
