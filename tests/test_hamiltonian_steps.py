"""Structured Magnus steps for Hamiltonian generators (fkev_slepc/periodic/hamiltonian.py,
docs/theory.md §18.7 "Hamiltonian steps").

Known answers: the structured commutator is A@B - B@A and stays in sp(2n); packing keeps every
entry of a Hamiltonian matrix; the structured interpolant and Magnus steps integrate the same
function as the generic ones, so the monodromy agrees to round-off with the same step count (the
thesis Bahgat–Willmert mesh and its link-component basis to 1e-12; a frozen-mode basis, whose Φ
has a round-off floor above that, within the floor); a damped or
non-Lagrangian generator is not Hamiltonian and keeps the generic path, unchanged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic import hamiltonian as ham
from fkev_slepc.periodic.components import link_components
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.interpolant import TrigInterpolant
from fkev_slepc.periodic.magnus import magnus_generators, monodromy
from fkev_slepc.periodic.reduce import compress, frozen_pool
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene import load_scene

RUNS = Path(__file__).resolve().parents[1] / "runs"
BW, BW_DAMPED = RUNS / "bahgat-willmert-1976.toml", RUNS / "bahgat-willmert-damped.toml"


def _random_hamiltonian(rng, k: int, n: int) -> np.ndarray:
    E, F, G = rng.standard_normal((3, k, n, n))
    return ham.assemble(np.stack([E, F + np.swapaxes(F, 1, 2), G + np.swapaxes(G, 1, 2)]))


def _phi_rel(a, b) -> float:
    return float(np.linalg.norm(a.phi - b.phi) / np.linalg.norm(a.phi))


def test_pack_unpack_round_trips_and_the_structured_commutator_is_the_commutator():
    rng = np.random.default_rng(7)
    A, B = _random_hamiltonian(rng, 3, 5), _random_hamiltonian(rng, 3, 5)
    assert ham.hamiltonian_residual(A) == 0.0
    P = ham.pack(A)
    assert P.shape == (3, 5 * 5 + 5 * 6)
    np.testing.assert_array_equal(ham.assemble(ham.unpack(P, 5)), A)
    C = ham.assemble(ham.commutator(ham.unpack(ham.pack(A), 5), ham.unpack(ham.pack(B), 5)))
    exact = A @ B - B @ A
    assert np.max(np.abs(C - exact)) <= 1e-14 * np.max(np.abs(exact))
    assert ham.hamiltonian_residual(C) == 0.0  # sp(2n) is closed: the blocks are Hamiltonian by construction
    # the order-4 and order-6 Ω: the same formula with either commutator
    nodes = np.stack([_random_hamiltonian(rng, 2, 4) for _ in range(3)], axis=1)  # (steps, nodes, 2n, 2n)
    blocks = np.moveaxis(ham.unpack(ham.pack(nodes.reshape(6, 8, 8)), 4).reshape(3, 2, 3, 4, 4), 2, 1)  # (3, nodes, steps, n, n)
    for order in (4, 6):
        generic = magnus_generators(nodes, 0.1, order)
        structured = ham.assemble(magnus_generators(blocks, 0.1, order, commutator=ham.commutator))
        assert np.max(np.abs(structured - generic)) <= 1e-14 * np.max(np.abs(generic))
    # JA not symmetric: not Hamiltonian
    assert not ham.is_hamiltonian(A + 1e-6 * np.eye(10)[None])


def _both_paths(monkeypatch, model, omega, **kw):
    out = {}
    for structured in (False, True):
        monkeypatch.setattr(PeriodicSystem, "hamiltonian_steps", structured)
        out[structured] = floquet_multipliers(PeriodicSystem(model, omega, "full", **kw),
                                              PeriodicSettings(reduce="none"))
    return out[False], out[True]


def test_the_thesis_mesh_and_a_link_basis_take_structured_steps_to_the_same_monodromy(monkeypatch):
    """Bahgat–Willmert, thesis mesh (1 element per link, 9 DOFs), 500 rad/s, and its link-component
    basis of 2 modes per link: Φ of the structured steps within 1e-12 of the generic one (measured
    6e-14 and 2e-14), the same step count, |μ| = 1 kept."""
    model = Model(load_scene(BW), ("full",))
    assert isinstance(PeriodicSystem(model, 500.0).interpolant().generator, ham.HamiltonianInterpolant)
    for kw in ({}, {"basis": link_components(model).basis(2)}):
        generic, structured = _both_paths(monkeypatch, model, 500.0, **kw)
        assert structured.monodromy.steps == generic.monodromy.steps
        assert _phi_rel(generic.monodromy, structured.monodromy) <= 1e-12
        assert abs(structured.max_abs - 1.0) <= 1e-12


def test_a_frozen_mode_basis_is_hamiltonian_and_steps_the_same_function():
    """The frozen-mode basis (2 modes at 8 angles, compressed) of the same scene: its samples are
    Hamiltonian to round-off (measured 6e-13 of max|A|: the projected M⁻¹), so the structured
    interpolant holds their symmetric part. Here ‖Φ‖ ≈ 540 and cond Φ ≈ 2.5e5 put the round-off
    floor above 1e-12: the generic steps of the same symmetric samples, and of those samples
    perturbed by one ulp (seeded), differ by 5.7e-12–8.6e-12 and 8.1e-12–8.5e-12 (fixed 512 steps:
    the integrators compared, not the step count; the frozen modes' basis, hence the numbers, vary
    with the solver's start between runs). The structured Φ is within twice that floor, and 2e-11."""
    model = Model(load_scene(BW), ("full",))
    basis = compress(frozen_pool(model, 500.0, "full", 2, 8, 0.0), 1e-10)
    gen = PeriodicSystem(model, 500.0, basis=basis).interpolant().generator
    assert isinstance(gen, ham.HamiltonianInterpolant) and 0.0 < ham.hamiltonian_residual(gen.S) <= 1e-11
    S = ham.assemble(ham.unpack(ham.pack(gen.S), gen.S.shape[1] // 2))
    ulp = S * (1.0 + np.finfo(float).eps * np.random.default_rng(1).standard_normal(S.shape))
    same, perturbed = (TrigInterpolant(0.0, X, drop=1e-13) for X in (S, ulp))
    assert same.harmonics.size == gen.harmonics.size
    a, b, floor = (monodromy(g, 2.0 * np.pi, steps=512) for g in (same, gen, perturbed))
    assert _phi_rel(a, b) <= min(2.0 * _phi_rel(a, floor), 2e-11)


@pytest.mark.parametrize("path, case, omega", [(BW_DAMPED, "full", 1000.0), (BW, "no_coriolis", 500.0)])
def test_damped_or_non_lagrangian_generators_keep_the_generic_path(monkeypatch, path, case, omega):
    """The Rayleigh-damped Bahgat–Willmert scene (C_d M⁻¹ in the (2, 2) block: residual 0.1) and
    the non-Lagrangian no_coriolis case in (q, q̇) (0.85): not Hamiltonian, the generic interpolant,
    and the monodromy identical with the structure switched on or off."""
    model = Model(load_scene(path), (case,))
    gen = PeriodicSystem(model, omega, case).interpolant().generator
    assert type(gen) is TrigInterpolant and ham.hamiltonian_residual(gen.S) > 1e-3
    if case == "full":
        out = {}
        for structured in (False, True):
            monkeypatch.setattr(PeriodicSystem, "hamiltonian_steps", structured)
            out[structured] = floquet_multipliers(PeriodicSystem(model, omega, case),
                                                  PeriodicSettings(reduce="none", steps=256))
        np.testing.assert_array_equal(out[False].monodromy.phi, out[True].monodromy.phi)


def test_forced_steps_are_the_augmented_steps():
    """The response's shooting with a forcing (fkev_slepc/periodic/shooting.py): the structured
    augmented steps (hamiltonian.forced) give the generic augmented Ω on random Hamiltonian A and
    columns b (orders 4 and 6, two load columns), and on the thesis mesh at 500 rad/s (the response's
    generator and load: the gravity and inertia loads of its scene) the same Φ and particular
    state as the generic steps at 512 steps to 1e-12; a generic (damped) generator gets None."""
    rng = np.random.default_rng(3)
    A = _random_hamiltonian(rng, 6, 4).reshape(2, 3, 8, 8)  # (steps, nodes, 2n, 2n)
    b = rng.standard_normal((2, 3, 8, 2))
    G = np.zeros((2, 3, 10, 10))
    G[:, :, :8, :8], G[:, :, :8, 8:] = A, b
    blocks = np.moveaxis(ham.unpack(ham.pack(A.reshape(6, 8, 8)), 4).reshape(3, 2, 3, 4, 4), 2, 1)
    for order in (4, 6):
        generic = magnus_generators(G, 0.1, order)
        x = magnus_generators(ham._Affine(blocks, np.moveaxis(b, 1, 0)), 0.1, order, commutator=ham._affine_commutator)
        structured = ham._Forced._assemble(x.B, x.b)
        assert np.max(np.abs(structured - generic)) <= 1e-14 * np.max(np.abs(generic))
    model = Model(load_scene(BW), ("full",))
    system = PeriodicSystem(model, 500.0, gravity=(0.0, -9.81))
    gen = system.interpolant().generator
    tau = 2.0 * np.pi * np.arange(64) / 64
    load = TrigInterpolant(0.0, system.forcing(tau)[:, :, None])
    forcing = lambda t: load(t)[:, :, 0]  # noqa: E731
    structured = monodromy(ham.forced(gen, forcing), 2.0 * np.pi, steps=512)
    generic = monodromy(gen, 2.0 * np.pi, forcing=forcing, steps=512)
    n = generic.phi.shape[0]
    phi = structured.phi[:n, :n]  # the augmented [[Φ, x_p], [0, 1]]
    assert np.linalg.norm(phi - generic.phi) <= 1e-12 * np.linalg.norm(generic.phi)
    assert np.linalg.norm(structured.phi[:n, n] - generic.particular) <= 1e-12 * np.linalg.norm(generic.particular)
    damped = PeriodicSystem(Model(load_scene(BW_DAMPED), ("full",)), 1000.0).interpolant().generator
    assert ham.forced(damped, forcing) is None
