"""Stage 2 — the instantaneous structure: mechanism and mesh, rigid-body kinematics and
kinetostatics, element matrices, assembly, and the per-(angle, speed, case) operators M, C, K."""
