"""The design check of every design point of a design study (design/point_checks.py, fkev design
--stress/--sensitivity, Study.design; docs/design.md, "Design sweeps"): the peak stress and safety
factors equal `fkev design-check` at that point to 1e-10, the pin loads and the torque range equal
`fkev loads` to 1e-12, the weak-axis factor by hand, and the sensitivities against closed forms."""

import csv
import io
import json
import math
import shutil

import numpy as np
import pytest
from clitools import ROOT, fkev

import fkev_slepc as fk
from fkev_slepc.sweep.session import RunRefused

SCENE = ROOT / "runs" / "slider-crank-design.toml"
WIDTH = "links[rod].section.width_m"  # the rod's out-of-plane width (its weak axis)
ANGLES = "0:330:30"
GRID = dict(speeds=[0, 100], cases=["full"], angles=ANGLES, modes=1)
THETA = np.arange(0.0, 360.0, 30.0)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("dcheck") / "d.h5"
    ds = fk.load(SCENE).design({WIDTH: [0.005, 0.006]}, output=out, stress=True, sensitivity=True, harmonics=8,
                               **GRID)
    return out, ds


def _point_scene(tmp_path, width):
    path = tmp_path / f"w{width}.toml"
    path.write_text(fk.load(SCENE).replace(WIDTH, width).scene.source_text)
    return path


def test_peak_stress_and_factors_equal_fkev_design_check(study, tmp_path):
    """At a design point the table's peak |σ|, static and fatigue factors per link are `fkev
    design-check --json` at that point and speed (same angles, harmonics) to 1e-10; at Ω = 0
    without gravity the linkage is unstressed."""
    _, ds = study
    r = fkev("design-check", _point_scene(tmp_path, 0.006), "--speed", "100", "--angles", ANGLES, "--harmonics", "8",
             "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)["links"]
    at = ds.sel({WIDTH: 0.006, "speed_rad_s": 100.0, "case": "full"})
    for name in ("crank", "rod"):
        for key in ("peak_stress_pa", "static_sf", "fatigue_sf"):
            assert float(at[key].sel(link=name)) == pytest.approx(d[name][key], rel=1e-10), (name, key)
    assert ds.fatigue_sf.attrs["fatigue_criterion"] == "goodman"
    np.testing.assert_array_equal(ds.peak_stress_pa.sel(speed_rad_s=0.0).values, 0.0)


def test_pin_loads_and_torque_range_equal_fkev_loads(study, tmp_path):
    """Torque min/max, every joint's peak |F| and the wrist pin's peak equal `fkev loads --json`
    (peak_n, pin_peak_n, driving_torque_n_m) at the design point to 1e-12."""
    _, ds = study
    r = fkev("loads", _point_scene(tmp_path, 0.005), "--speed", "100", "--angles", ANGLES, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    at = ds.sel({WIDTH: 0.005, "speed_rad_s": 100.0})
    torque = np.array(d["driving_torque_n_m"])
    assert float(at.torque_min_n_m) == pytest.approx(torque.min(), rel=1e-12)
    assert float(at.torque_max_n_m) == pytest.approx(torque.max(), rel=1e-12)
    for joint in ("O", "A", "B"):
        assert float(at.peak_joint_force_n.sel(joint=joint)) == pytest.approx(d["joints"][joint]["peak_n"], rel=1e-12)
    assert float(at.peak_pin_force_n.sel(joint="B")) == pytest.approx(d["joints"]["B"]["pin_peak_n"], rel=1e-12)
    assert np.isnan(at.peak_pin_force_n.sel(joint="A"))  # a pin joint has no wrist pin of its own
    # the wrist pin at top dead centre carries the block's m r Ω² (1 + r/L): 0.3 x 0.15 x 100² x 1.5 = 675 N
    assert float(at.peak_pin_force_n.sel(joint="B")) == pytest.approx(675.0, rel=1e-12)


def test_buckling_factor_by_hand(study):
    """buckling_sf = π² E (h w³/12) / L² / |N_min|, N_min the most compressive kinetostatic axial
    force of the rod over the angles (Study.loads); the crank is never in compression there."""
    _, ds = study
    for width in (0.005, 0.006):
        jl = fk.load(SCENE).replace(WIDTH, width).loads(100.0, THETA)
        n_min = jl.link_axial(1)[1].min()
        hand = math.pi**2 * 2.05e11 * (0.020 * width**3 / 12) / 0.3**2 / abs(n_min)
        at = ds.sel({WIDTH: width, "speed_rad_s": 100.0})
        assert float(at.buckling_sf.sel(link="rod")) == pytest.approx(hand, rel=1e-12)
        assert float(at.min_axial_force_n.sel(link="rod")) == n_min
    assert np.isnan(ds.buckling_sf.sel(link="crank", speed_rad_s=100.0)).all()


def test_sensitivities_against_closed_forms(tmp_path):
    """d(buckling SF)/dK = −2 SF/K (P_cr ∝ 1/K², the loads do not see K) and the torque range
    does not move with K (exactly 0); the torque is linear in the block mass, so d τ_max/dm is
    τ(m + 1) − τ(m) at the angle of the maximum."""
    key_k, key_m = "links[rod].buckling_length_factor", "joints[B].slider_mass_kg"
    ds = fk.load(SCENE).design({key_k: [1.0, 0.7], key_m: [0.3]}, output=tmp_path / "s.h5", sensitivity=True,
                               speeds=[100], cases=["full"], angles=ANGLES, modes=1)
    for k in (1.0, 0.7):
        at = ds.sel({key_k: k, key_m: 0.3, "speed_rad_s": 100.0})
        sf = float(at.buckling_sf.sel(link="rod"))
        d_sf = float(at.sensitivity_buckling_sf.sel(design_key=key_k, link="rod"))
        assert d_sf == pytest.approx(-2 * sf / k, rel=1e-7)
        assert float(at.sensitivity_torque_max_n_m.sel(design_key=key_k)) == 0.0
    base = fk.load(SCENE)
    t0 = base.loads(100.0, THETA).torque
    t1 = base.replace(key_m, 1.3).loads(100.0, THETA).torque
    at = ds.sel({key_k: 1.0, key_m: 0.3, "speed_rad_s": 100.0})
    slope = (t1 - t0)[np.argmax(t0)]
    assert float(at.sensitivity_torque_max_n_m.sel(design_key=key_m)) == pytest.approx(slope, rel=1e-6)


def test_cli_json_and_csv_rows_and_bad_input(study, tmp_path):
    """`fkev design --stress --json` gives one row per design point and speed with the archive's
    values; --csv the same rows; a bad --harmonics or a crank acceleration with --stress is refused
    (exit 2, the field named) before anything is solved; a resume with other columns is refused."""
    out, ds = study
    args = ("design", SCENE, "--set", f"{WIDTH}=0.006", "--speeds", "100", "--cases", "full", "--angles", ANGLES,
            "--modes", "1", "--stress", "--harmonics", "8", "-o", tmp_path / "c.h5")
    r = fkev(*args, "--json", "--csv", tmp_path / "c.csv")
    assert r.returncode == 0, r.stderr
    (row,) = json.loads(r.stdout)["rows"]
    at = ds.sel({WIDTH: 0.006, "speed_rad_s": 100.0})
    assert row[WIDTH] == 0.006 and row["speed_rad_s"] == 100.0
    assert row["peak_stress_pa.full.rod"] == pytest.approx(float(at.peak_stress_pa.sel(case="full", link="rod")),
                                                           rel=1e-12)
    assert row["peak_pin_force_n.B"] == float(at.peak_pin_force_n.sel(joint="B"))
    assert "peak_pin_force_n.A" not in row  # NaN in every row: left out
    (crow,) = list(csv.DictReader(io.StringIO((tmp_path / "c.csv").read_text())))
    assert list(crow) == list(row) and float(crow["torque_max_n_m"]) == row["torque_max_n_m"]
    bad = fkev(*args[:-2], "-o", tmp_path / "b.h5", "--harmonics", "0")
    assert bad.returncode == 2 and "--harmonics: must be an integer >= 2: the error estimate compares H with H/2 (got 0)" in bad.stderr, bad.stderr
    accel = tmp_path / "accel.toml"
    accel.write_text(SCENE.read_text().replace("speeds_rad_s = [0.0, 100.0]",
                                               "speeds_rad_s = [0.0, 100.0]\nacceleration_rad_s2 = 5.0"))
    bad = fkev("design", accel, *args[2:-2], "-o", tmp_path / "a.h5")
    assert bad.returncode == 2 and "driver.acceleration_rad_s2" in bad.stderr, bad.stderr
    assert not (tmp_path / "a.h5").exists() and not (tmp_path / "b.h5").exists()
    copy = tmp_path / "copy.h5"
    shutil.copy(out, copy)
    with pytest.raises(RunRefused, match="other design-check columns"):
        fk.load(SCENE).design({WIDTH: [0.005, 0.006]}, output=copy, resume=True, **GRID)


# The stress columns of the study below at c0c0b0b (a Model per speed x case), indexed
# [width, speed, case, link] (widths 5, 6, 7 mm; 60, 100 rad/s; full, no_coriolis; crank, rod).
BEFORE = {
    "peak_stress_pa": [[[[17366554.462132234, 9712424.079261968], [17369964.75535877, 9708130.625087794]],
                        [[48383842.65468414, 26862681.646092623], [48410549.9635251, 26829011.607873216]]],
                       [[[18449695.396461047, 9394403.32375965], [18453922.515386023, 9389785.166890625]],
                        [[51409526.083738565, 25990327.91890848], [51442651.264250875, 25954062.803076968]]],
                       [[[19533142.880596824, 9167166.65099138], [19538238.713691037, 9162230.019719139]],
                        [[54437385.88476209, 25366235.79529164], [54477343.41252115, 25327424.576560117]]]],
    "static_sf": [[[[30.51843134201806, 54.56928112639351], [30.512439573977307, 54.593414578742035]],
                   [[10.954070014294112, 19.729973611070672], [10.94802683298017, 19.75473445486403]]],
                  [[[28.726761532424142, 56.416568645670345], [28.72018128168202, 56.44431587943418]],
                   [[10.309373386105678, 20.392201347117844], [10.302734928600161, 20.42069498025435]]],
                  [[[27.133370356209987, 57.81502837004532], [27.126293611541993, 57.84617924449548]],
                   [[9.735956115195377, 20.89391600224642], [9.728815077979446, 20.925933404634492]]]],
    "fatigue_sf": [[[[18.392110132775294, 34.087262916137874], [18.388442891772247, 34.09443002072764]],
                    [[6.601175569367843, 12.308241255653916], [6.597477750770228, 12.31556397180553]]],
                   [[[17.312160861965925, 34.925052288790944], [17.30812702661041, 34.933268232020865]],
                    [[6.2125808551593655, 12.606317918554108], [6.208512240731409, 12.614721186185465]]],
                   [[[16.35173943319716, 35.54912001888356], [16.347395930091697, 35.5583237617999]],
                    [[5.866953603531431, 12.828380366695026], [5.862571558841158, 12.837803264951024]]]],
}


def test_stress_study_builds_one_model_per_design_point_for_its_solve(tmp_path, monkeypatch):
    """Issue 34 item 2: a --stress study over 3 design points x 2 speeds x 2 cases solves every
    design point's frequencies and its 4 periodic responses (and their overflow checks) on one Model
    (every construction counted by a wrapper of the real Model.__init__): 4 in all (c0c0b0b: 25;
    b8fb00b: 10) = 1 for the base sweep (the study's pool) + 1 per point, built by the checks of
    every point before anything is solved (assembly and overflow as `fkev check`, the periodic
    limits of every case) and kept for its solve, none in the solve itself (c0c0b0b: 15). The stress
    columns are those of c0c0b0b (a Model per speed x case) to 1e-12."""
    from fkev_slepc.design.study import DesignSolver
    from fkev_slepc.model.operators import Model

    built, in_solve = [], []
    real_init, real_solve = Model.__init__, DesignSolver.solve

    def counted(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        built.append(bool(in_solve))

    def solving(self, *args, **kwargs):
        in_solve.append(1)
        try:
            return real_solve(self, *args, **kwargs)
        finally:
            in_solve.pop()

    monkeypatch.setattr(Model, "__init__", counted)
    monkeypatch.setattr(DesignSolver, "solve", solving)
    ds = fk.load(SCENE).design({WIDTH: [0.005, 0.006, 0.007]}, output=tmp_path / "s.h5", stress=True, harmonics=8,
                               speeds=[60.0, 100.0], cases=["full", "no_coriolis"], angles=ANGLES, modes=1)
    assert sum(built) == 0 and len(built) == 1 + 3, built
    for key, want in BEFORE.items():
        got = ds[key].transpose(WIDTH, "speed_rad_s", "case", "link").values
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0, err_msg=key)
