"""One place for the limits of the periodic commands (issue 34 item 3, fkev_slepc/periodic/limits.py):
``Study.response``, ``Study.design_check``, ``fkev response`` and ``fkev design-check`` refuse the
same oversize model, before any solve, with the same message."""

from __future__ import annotations

import pytest

import fkev_slepc as fk
from clitools import ROOT, fkev
from fkev_slepc.periodic import limits
from fkev_slepc.scene import SceneError

SCENE = ROOT / "runs" / "slider-crank-design.toml"
ELEMENTS = 400  # 2,400 free DOFs: past MAX_COMPONENT_DOFS, built in a blink (no model)


def _api_message(call) -> str:
    with pytest.raises(SceneError) as err:
        call()
    (problem,) = err.value.problems
    assert problem.path == "elements"
    return problem.message


def test_study_and_cli_refuse_the_same_oversize_model_in_the_same_words():
    study = fk.load(SCENE, elements=ELEMENTS)
    assert study.n_free > limits.MAX_COMPONENT_DOFS  # the refusal below is the limit's, not another's
    via_response = _api_message(lambda: study.response(100.0))
    via_check = _api_message(lambda: study.design_check(100.0))
    assert via_response == via_check
    assert f"{study.n_free} free DOFs exceed {limits.MAX_COMPONENT_DOFS}" in via_response
    for command in (("response", "--speed", "100"), ("design-check", "--speed", "100")):
        r = fkev(command[0], SCENE, "--elements", str(ELEMENTS), *command[1:], timeout=60)
        assert r.returncode == 2, r.stdout + r.stderr
        assert f"  --elements: {via_response}" in r.stderr.splitlines(), r.stderr
        assert r.stdout == ""


def test_study_runup_and_fkev_runup_refuse_the_same_oversize_model():
    study = fk.load(SCENE, elements=200)  # 1,200 free DOFs: past MAX_PERIODIC_DOFS (the run-up's full model)
    msg = _api_message(lambda: study.runup(100.0, 1))
    assert f"exceed {limits.MAX_PERIODIC_DOFS}" in msg
    r = fkev("runup", SCENE, "--elements", "200", "--speed", "100", "--revolutions", "1", timeout=60)
    assert r.returncode == 2 and f"  --elements: {msg}" in r.stderr.splitlines(), r.stderr
    assert r.stdout == ""


def test_full_model_limit_and_harmonics_named_by_the_callers_names():
    study = fk.load(SCENE, elements=200)  # 1,200 free DOFs: past MAX_PERIODIC_DOFS on the full model
    (p,) = limits.size_problems(study.scene, True, None, "none", {"elements": "--elements"})
    assert p.path == "--elements" and f"exceed {limits.MAX_PERIODIC_DOFS}" in p.message
    assert limits.size_problems(study.scene, False) == []  # a frozen-time command takes it
    small = fk.load(SCENE, elements=4).scene
    (h,) = limits.size_problems(small, True, 10_000, "none")
    assert h.path == "harmonics" and "harmonics x" in h.message


@pytest.mark.parametrize("command", ["response", "design-check"])
def test_the_cli_checks_and_solves_a_response_on_one_model(command, monkeypatch, capsys):
    """The preflight's overflow check of ``fkev response`` / ``fkev design-check`` and the response
    itself share one in-plane Model (every construction counted by a wrapper of the real
    Model.__init__; the design check's out-of-plane problem, a plane of its own, builds one more)."""
    from fkev_slepc.cli import main
    from fkev_slepc.model.operators import Model

    built = []
    real = Model.__init__

    def counted(self, scene, cases=None, plane="in", *args, **kwargs):
        real(self, scene, cases, plane, *args, **kwargs)
        built.append(self.plane)

    monkeypatch.setattr(Model, "__init__", counted)
    code = main([command, str(SCENE), "--speed", "100", "--harmonics", "8", "--tol", "0.5", "--json"])
    assert code == 0, capsys.readouterr().err
    assert built.count("in") == 1, built  # b8fb00b: 2 (one for the preflight, one for the response)
