"""The running-speed methods of :class:`~fkev_slepc.api.study.Study` (docs/response.md):
kinetostatic loads and the steady periodic response. A mixin, so that study.py stays one
module of the operating-point and sweep methods; the bodies are in api/loads.py and
api/response.py."""

from __future__ import annotations

from fkev_slepc.api.floquet import study_floquet
from fkev_slepc.api.loads import study_loads
from fkev_slepc.api.response import study_response
from fkev_slepc.api.response_speeds import response_vs_speed
from fkev_slepc.api.runup import study_runup
from fkev_slepc.design.check import design_check


class RunningSpeed:
    """``Study.loads``, ``Study.response``, ``Study.design_check``, ``Study.floquet`` and ``Study.runup`` (``self.scene`` is
    the study's scene; their models come from ``self.pool``, fkev_slepc/api/pool.py; ``loads`` needs none)."""

    def loads(self, speed_rad_s: float, angles_deg=None, accel_rad_s2=None, gravity_m_s2=None):
        """Kinetostatics over the crank cycle (``fkev loads``): :func:`fkev_slepc.api.loads.study_loads`."""
        return study_loads(self.scene, speed_rad_s, angles_deg, accel_rad_s2, gravity_m_s2)

    def response(self, speed_rad_s: float, case="full", angles_deg=None, **options):
        """The steady periodic elastic response (``fkev response``):
        :func:`fkev_slepc.api.response.study_response` (options ``gravity_m_s2``, ``harmonics``,
        ``tol``, ``shoot``, ``stations``, ``settings``: a
        :class:`~fkev_slepc.periodic.settings.PeriodicSettings` that the other options override)."""
        return study_response(self.scene, speed_rad_s, case, angles_deg, model_for=self.pool.model_for, **options)

    def design_check(self, speed_rad_s: float, criterion: str = "goodman", **options):
        """Per link peak |σ|, static and fatigue safety factors, weak-axis buckling factor and peak
        pin loads, and the lowest out-of-plane frequency over the cycle with its crank-order margin
        (``out_of_plane``; None where the scene has no out-of-plane section) (``fkev design-check``):
        :func:`fkev_slepc.design.check.design_check` (options ``case``, ``angles_deg``,
        ``gravity_m_s2``, ``harmonics``, ``tol``, ``threshold``, ``settings``)."""
        return design_check(self.scene, speed_rad_s, criterion=criterion, model_for=self.pool.model_for, **options)

    def response_vs_speed(self, speeds_rad_s, case="full", output=None, **options):
        """Peak response of every station over a speed range (``fkev response --speeds``):
        :func:`fkev_slepc.api.response_speeds.response_vs_speed`; with ``output`` archived there
        over the MPI ranks of ``comm`` and resumable (``resume``, ``force``):
        :func:`fkev_slepc.api.response_archive.archived_response_vs_speed` (``settings``: a
        PeriodicSettings, default ``periodic.settings.SCAN``, archived whole and compared whole on ``resume``)."""
        from fkev_slepc.api.response_archive import archived_response_vs_speed

        if output is None:
            return response_vs_speed(self.scene, speeds_rad_s, case, model_for=self.pool.model_for, **options)
        return archived_response_vs_speed(self.scene, speeds_rad_s, case, output, model_for=self.pool.model_for,
                                          **options)

    def floquet(self, speeds_rad_s=None, case="full", output=None, **options):
        """Floquet multipliers over a speed range, unstable bands labelled (``fkev floquet``):
        :func:`fkev_slepc.api.floquet.study_floquet` (options: angles_deg, resume, force, tol, rtol,
        resonance_order, probe, reduce, ``settings``: a :class:`~fkev_slepc.periodic.settings.PeriodicSettings`
        that those override, archived whole in ``/floquet/settings`` and compared whole on ``resume``, ...)."""
        return study_floquet(self, speeds_rad_s, case, output, **options)

    def runup(self, speed_rad_s=None, revolutions=None, *, ramp_rad_s=None, duration_s=None, case="full", **options):
        """The run-up in time (``fkev runup``): a constant ``speed_rad_s`` for ``revolutions``, or a linear
        ``ramp_rad_s`` (W0, W1) over ``duration_s``: :func:`fkev_slepc.api.runup.study_runup` (options
        ``reduce``, ``start``, ``steps_per_revolution``, ``gravity_m_s2``, ``damping``, ``output``, ``resume``,
        ``progress``); ``.as_dict()`` has ``time_s``, ``speed_rad_s`` and per link ``peak_stress_pa``,
        ``peak_deflection_m``, one value per revolution."""
        return study_runup(self.scene, speed=speed_rad_s, revolutions=revolutions, ramp=ramp_rad_s,
                           duration=duration_s, case=case, model_for=self.pool.model_for, **options)
