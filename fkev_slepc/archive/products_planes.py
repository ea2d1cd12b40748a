"""The ``/planes/out`` product's table (docs/archive.md): the out-of-plane sweep (docs/theory.md §19) of the
archive's own grid, beside the in-plane sweep of the root group.

A two-plane archive (``fkev run --plane both``, fkev_slepc/sweep/plane_run.py) keeps the in-plane sweep where
every archive has it (root group, ``/mesh``, ``/tracking``, ``/modes``: readers of one-plane archives read it
unchanged) and adds the out-of-plane one as a product solved unit by unit (one crank angle, its (speed, case)
points inside) on the same crank angles, speeds, cases and modes: the root scales. Its rows are the sweep's
rows of :data:`fkev_slepc.archive.products.SWEEP` moved under ``planes/out/``; what has the length of the
model's free DOFs (mode shapes, the eigenvector entries of tracking, the DOF map of the nodes) gets its own
scales there, since the out-of-plane model has other DOFs (θ_X, θ_Y, w per node) than the in-plane one.
"""

from __future__ import annotations

from dataclasses import replace

from fkev_slepc.archive.product_types import ANGLE, CASE, SPEED, STRING, Product, Var, error_table

OUT = "planes/out"
PLANES_GROUP = "planes"


def moved(v: Var, scales: dict) -> Var:
    """The sweep row ``v`` under ``planes/out/`` (its DOF-sized axes on the plane's own ``scales``)."""
    return replace(v, path=f"{OUT}/{v.path}", dims=tuple(scales.get(d, d) for d in v.dims),
                   rows=scales.get(v.rows, v.rows))


def plane_product(frequency, tracked, eigenvalue, residual, damping, max_real, status, signature,
                  fallback, shape, node_dofs, dofs: str, free_dof: str, component: str, node: str,
                  tracking: tuple = ()) -> tuple[Product, dict]:
    """The out-of-plane product built from the in-plane sweep's rows, and ``{sweep path: plane path}`` of the
    rows its units write (what :class:`~fkev_slepc.sweep.runner.Sweep` returns, moved). ``tracking``: the
    further rows of tracking (along speed, the refined angles with their angle scale), moved as they are."""
    scales = {d: f"{OUT}/{d}" for d in (dofs, free_dof, component, node)}
    scales.update({v.path: f"{OUT}/{v.path}" for v in tracking if v.scale})
    own = (
        Var(scales[dofs], (scales[dofs],), "i4", "1", "free DOF index of the kept entries (out of plane)",
            scale=True, needs="signatures"),
        Var(scales[free_dof], (scales[free_dof],), "i4", "1", "free DOF index (out of plane)", scale=True,
            needs="shapes"),
        Var(scales[component], (scales[component],), STRING, "1", "nodal DOF out of plane (rotations about X and Y, "
            "displacement along Z)", scale=True, needs="mechanism", values=("theta_X", "theta_Y", "w")),
        Var(scales[node], (scales[node],), "i4", "1", "node number (those of /mesh; here so that the group opens "
            "with xarray on its own)", scale=True, needs="mechanism"),
    )
    rows = tuple(moved(v, scales) for v in (frequency, tracked, eigenvalue, residual, damping, max_real, status,
                                            signature, fallback, shape) + tuple(tracking))
    dof_map = replace(moved(node_dofs, scales), long_name="free DOF index of (theta_X, theta_Y, w) at each node out "
                      "of plane, -1 if constrained", source=None)
    errors = error_table(f"{OUT}/errors", ("angle", "speed", "case"))
    product = Product(
        name=OUT, unit_dims=(ANGLE,), point_dims=(SPEED, CASE), status=f"{OUT}/{status.path}",
        variables=own + rows + (dof_map,) + errors.rows, errors=errors,
        groups={PLANES_GROUP: "the planes of a two-plane archive beside the in-plane sweep of the root group",
                OUT: "the out-of-plane sweep (docs/theory.md §19) of the root grid: bending out of the plane and "
                     "torsion; attributes n_free (its DOFs) and the run's settings",
                f"{OUT}/errors": "messages of failed and not-converged out-of-plane points (one row per point)",
                f"{OUT}/tracking": "eigenvector entries at the out-of-plane free DOFs `dofs`, used to follow modes "
                                   "between neighbouring crank angles by MAC",
                f"{OUT}/tracking/refined": "extra crank angles solved out of plane only for mode tracking, where the "
                                           "MAC between neighbouring grid angles was ambiguous",
                f"{OUT}/modes": "out-of-plane mode shapes over the plane's free DOFs (node positions: /modes/node_xy)"},
    )
    written = {v.path: f"{OUT}/{v.path}" for v in (frequency, eigenvalue, residual, damping, max_real, signature,
                                                   shape)}
    return product, written
