"""``scripts/stress.py products``: adversarial inputs to the product commands and one-byte faults
in their archives (issue 27). Not part of the package.

1. **Inputs**: every entry of :data:`ADVERSARIAL` (each once a traceback, an unbounded run or a
   ``.tmp`` left behind) through ``fkev``: counted ``refused`` (exit 2, no traceback, the flag or
   key named, nothing written in the folder) or not.
2. **Faults**: a finished archive of each product (``fkev floquet``, ``fkev response --speeds -o``,
   ``fkev design``, Bahgat-Willmert with one element per link), then one byte changed in the stored
   values of every dataset of its group: ``fkev verify`` must flag it, ``--resume`` must refuse it
   (exit 2) and leave the file as it was (never re-stamped), and the product's reader and
   ``fkev_slepc.open_dataset`` of its group (the verified xarray read) must warn.
3. **A design point failing in its solve** (SLEPc limited to one iteration by ``-fkev_pep_max_it 1``:
   the 30-element coupler does not converge, the 1-element one does): exit 3, no minima for it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

from stresslib import ROOT, Tally

BW = ROOT / "runs/bahgat-willmert-1976.toml"
SCD = ROOT / "runs/slider-crank-design.toml"  # [materials] with strengths: a design check with factors
PACK = ROOT / "runs/packaging-slider-crank.toml"  # [[loads]]: the 800 N cut
FLAT = ROOT / "runs/flat-rod-slider-crank.toml"  # the out-of-plane problem from section shapes
SMALL_CHECK = ("--harmonics", "4", "--elements", "1")
ONE = ("--elements", "1")
FQ = ("--angles", "0:360:90", "--no-critical")
ADVERSARIAL = {  # id: (fkev arguments, with {tmp} and the scene builders of SCENES, what the one line names)
    "floquet-speed-1e155": (("floquet", BW, *ONE, *FQ, "--speeds", "1e155", "-o", "{tmp}/f.h5"), "--speeds"),
    "floquet-speed-1e-300": (("floquet", BW, *ONE, *FQ, "--speeds", "1e-300", "-o", "{tmp}/f.h5"), "--speeds"),
    "response-speed-1e155": (("response", BW, *ONE, "--speed", "1e155"), "--speed"),
    "loads-speed-1e155": (("loads", BW, *ONE, "--speed", "1e155"), "--speed"),
    "floquet-beta-1e30": (("floquet", "beta", *ONE, *FQ, "--speeds", "100", "-o", "{tmp}/f.h5"), "damping"),
    "floquet-alpha-1e30": (("floquet", "alpha", *ONE, *FQ, "--speeds", "100", "-o", "{tmp}/f.h5"), "damping"),
    "response-beta-1e30": (("response", "beta", *ONE, "--speed", "100"), "damping"),
    "response-alpha-1e30": (("response", "alpha", *ONE, "--speed", "100"), "damping"),
    "response-harmonics-100000": (("response", BW, *ONE, "--speed", "100", "--harmonics", "100000"), "--harmonics"),
    "floquet-plot-xyz": (("floquet", BW, *ONE, *FQ, "--speeds", "100", "-o", "{tmp}/f.h5", "--plot", "{tmp}/x.xyz"),
                         "--plot"),
    "response-plot-xyz": (("response", BW, *ONE, "--speed", "100", "--plot", "{tmp}/x.xyz"), "--plot"),
    "response-plot-stations-xyz": (("response", BW, *ONE, "--speed", "100", "--plot-stations", "{tmp}/x.xyz"),
                                   "--plot-stations"),
    "loads-plot-xyz": (("loads", BW, *ONE, "--speed", "100", "--plot", "{tmp}/x.xyz"), "--plot"),
    "loads-plot-missing-folder": (("loads", BW, *ONE, "--speed", "100", "--plot", "{tmp}/no/x.png"), "--plot"),
    "loads-output-directory": (("loads", BW, *ONE, "--speed", "100", "-o", "{tmp}"), "-o"),
    "response-output-directory": (("response", BW, *ONE, "--speed", "100", "-o", "{tmp}"), "-o"),
    "response-elements-1000": (("response", BW, "--elements", "1000", "--speed", "100"), "--elements"),
    "floquet-elements-1000": (("floquet", BW, "--elements", "1000", *FQ, "--speeds", "100", "-o", "{tmp}/f.h5"),
                              "--elements"),
    "floquet-elements-200": (("floquet", BW, "--elements", "200", *FQ, "--speeds", "100", "-o", "{tmp}/f.h5"),
                             "--elements"),
    "point-elements-100000": (("point", BW, "--elements", "100000", "--speed", "100", "--angle", "10"), "--elements"),
    "floquet-speed-0.01": (("floquet", BW, *FQ, "--speeds", "0.01", "-o", "{tmp}/f.h5"), "--speeds"),
    "design-100001-points": (("design", BW, "--set", "links[0].length_m=0.1:0.2:0.000001", "-o", "{tmp}/d.h5"),
                             "--set"),
    "check-strict-height-1e155": (("check", "--strict", "height"), "height_m"),
    "check-strict-beta-1e30": (("check", "--strict", "beta"), "stiffness_proportional_s = 1e+30"),
    "design-set-driver-speeds": (("design", BW, "--set", "driver.speeds_rad_s=1", "-o", "{tmp}/d.h5"),
                                 "--set[driver.speeds_rad_s]"),
    "design-set-solver-option": (("design", BW, "--set", "solver.petsc.pep_max_it=1,2", "-o", "{tmp}/d.h5"),
                                 "--set[solver.petsc.pep_max_it]"),
    "point-sensitivity-typo": (("point", BW, *ONE, "--sensitivity", "links[1].lenght_m"),
                               "did you mean 'links[1].length_m'"),
    # issue 36 item 6: the design check, [[loads]], [materials] and the out-of-plane keys
    "design-check-speed-1e155": (("design-check", SCD, *SMALL_CHECK, "--speed", "1e155"), "--speed"),
    "design-check-elements-100000": (("design-check", SCD, "--elements", "100000"), "--elements"),
    "design-check-csv-missing-folder": (("design-check", SCD, *SMALL_CHECK, "--csv", "{tmp}/no/x.csv"), "--csv"),
    "design-check-csv-directory": (("design-check", SCD, *SMALL_CHECK, "--csv", "{tmp}"), "--csv"),
    "design-check-csv-stdout-json": (("design-check", SCD, *SMALL_CHECK, "--csv", "-", "--json"), "--csv"),
    "design-check-tol-0": (("design-check", SCD, *SMALL_CHECK, "--tol", "0"), "--tol"),
    "design-check-one-angle": (("design-check", SCD, *SMALL_CHECK, "--angles", "10"), "--angles"),
    "design-check-modulus-1e300": (("design-check", "modulus", *SMALL_CHECK), "links"),
    "design-check-out-of-plane-speed-1e155": (("design-check", FLAT, *SMALL_CHECK, "--speed", "1e155"), "--speed"),
    "design-stress-one-angle": (("design", SCD, "--set", "links[rod].section.width_m=0.006", "--speeds", "100",
                                 "--angles", "0:90:30", "--stress", "--harmonics", "8", "-o", "{tmp}/d.h5"), "--angles"),
    "loads-at-no-joint": (("loads", "load-at", "--speed", "60"), "loads[0].at"),
    "response-load-at-no-joint": (("response", "load-at", "--speed", "60", "--harmonics", "4"), "loads[0].at"),
    "design-check-load-at-no-joint": (("design-check", "load-at", *SMALL_CHECK), "loads[0].at"),
    "loads-force-length": (("loads", "load-length", "--speed", "60"), "loads[0].fx_n"),
    "design-check-yield-negative": (("design-check", "yield", *SMALL_CHECK), "materials.steel_1045.yield_pa"),
    "design-check-material-key-typo": (("design-check", "endurance-typo", *SMALL_CHECK),
                                       "did you mean 'materials.steel_1045.endurance_pa'"),
    "point-out-of-plane-section-twice": (("point", "out-twice", "--plane", "out", "--speed", "100", "--angle", "0"),
                                         "links[1].second_moment_out_of_plane_m4"),
    "point-out-of-plane-bearing-scalar": (("point", "bearing", "--plane", "out", "--speed", "100", "--angle", "0"),
                                          "joints[2].bearing_stiffness_nm_rad"),
}


def _damped(folder: Path, key: str, value: str) -> Path:
    """runs/bahgat-willmert-damped.toml with one Rayleigh coefficient replaced."""
    src = BW.with_name("bahgat-willmert-damped.toml").read_text()
    lines = [f"{key} = {value}" if ln.startswith(f"{key} =") else ln for ln in src.splitlines()]
    path = folder / f"{key}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _height(folder: Path) -> Path:
    """B-W with a rectangular section of height 1e155 m (its h³ overflows)."""
    text = BW.read_text().replace("area_m2 = 1.61e-4            # 1.61 cm²\nsecond_moment_m4 = 8.66e-9   # 8.66e-1 cm⁴",
                                  'section = {shape = "rectangle", width_m = 0.00635, height_m = 1e155}')
    path = folder / "height.toml"
    path.write_text(text)
    return path


def _edited(folder: Path, base: Path, name: str, old: str, new: str) -> Path:
    """``base`` with its one line ``old`` replaced by ``new``, written as ``folder/name.toml``."""
    text = base.read_text()
    assert text.count(old) == 1, (base, old)
    path = folder / f"{name}.toml"
    path.write_text(text.replace(old, new))
    return path


FLAT_ROD_SECTION = 'section = {shape = "rectangle", width_m = 0.008, height_m = 0.020}'
SCENES = {"beta": lambda d: _damped(d, "stiffness_proportional_s", "1e30"),
          "alpha": lambda d: _damped(d, "mass_proportional_1_s", "1e30"), "height": _height,
          "modulus": lambda d: _edited(d, SCD, "modulus", "youngs_modulus_pa = 2.05e11", "youngs_modulus_pa = 1e300"),
          "load-at": lambda d: _edited(d, PACK, "load-at", 'at = "B"', 'at = "Z"'),
          "load-length": lambda d: _edited(d, PACK, "load-length", "fx_n = [0.0, 0.0, 800.0, 800.0, 0.0]",
                                           "fx_n = [0.0, 0.0, 800.0, 800.0]"),
          "yield": lambda d: _edited(d, SCD, "yield", "yield_pa = 5.30e8", "yield_pa = -5.30e8"),
          "endurance-typo": lambda d: _edited(d, SCD, "endurance-typo", "endurance_pa = 3.1e8", "endurence_pa = 3.1e8"),
          "out-twice": lambda d: _edited(d, FLAT, "out-twice", FLAT_ROD_SECTION,
                                         FLAT_ROD_SECTION + "\nsecond_moment_out_of_plane_m4 = 1e-9"),
          "bearing": lambda d: _edited(d, FLAT, "bearing", 'assembly = "ahead"',
                                       'assembly = "ahead"\nbearing_stiffness_nm_rad = -5.0')}


def arguments(case: str, folder: Path) -> tuple[list[str], str]:
    """The command line of ``ADVERSARIAL[case]`` with its scenes written into ``scenes`` and outputs in
    ``folder``, and what its refusal must name."""
    args, named = ADVERSARIAL[case]
    scenes = Path(tempfile.mkdtemp(prefix="scenes-"))
    return [str(SCENES[a](scenes)) if a in SCENES else str(a).replace("{tmp}", str(folder)) for a in args], named


def fkev(*args, timeout: float = 600):
    return subprocess.run([sys.executable, "-m", "fkev_slepc", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)))


def refused(r, named: str) -> bool:
    return r.returncode == 2 and "Traceback" not in r.stderr and named in r.stderr


PRODUCTS = {  # product: (the command that writes it, its group)
    "floquet": (("floquet", BW, *ONE, "--speeds", "100,200", *FQ, "--reduce", "none", "-q"), "floquet"),
    "response": (("response", BW, *ONE, "--speeds", "50", "--angles", "0:360:90", "--harmonics", "4",
                  "--no-shooting", "-q"), "response"),
    "design": (("design", BW, "--set", "links[0].length_m=0.127,0.13", "--angles", "0:360:90", "--speeds", "100",
                "--cases", "full", "-q"), "design"),
}


def _reader(product: str):
    if product == "floquet":
        from fkev_slepc.sweep.floquet_run import read_floquet as read
    elif product == "response":
        from fkev_slepc.api.response_archive import read_response as read
    else:
        from fkev_slepc.design.results import open_design as read
    return read


def _value_offsets(path: Path, group: str) -> dict:
    """dataset -> file offset of a byte inside its stored values (the 4th, or the last of a shorter
    storage; contiguous datasets with storage)."""
    import h5py

    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.chunks is None and obj.id.get_offset() is not None \
                    and obj.id.get_storage_size() > 0:
                out[obj.name] = obj.id.get_offset() + min(3, obj.id.get_storage_size() - 1)
        f[group].visititems(visit)
    return out


def cmd_products(args) -> Tally:
    from fkev_slepc import open_dataset
    from fkev_slepc.archive.reader import DamagedArchiveWarning
    from fkev_slepc.archive.verify import verify

    t = Tally("products (inputs and archive faults)")
    for case in ADVERSARIAL:
        with tempfile.TemporaryDirectory() as tmp:
            argv, named = arguments(case, Path(tmp))
            r = fkev(*argv)
            left = list(Path(tmp).iterdir())
            t.add("inputs refused in one line (exit 2)" if refused(r, named) and not left else "inputs not refused")
            if "Traceback" in r.stderr:
                t.add("tracebacks")
                t.notes.append(f"{case}: {r.stderr.strip().splitlines()[-1]}")
    for product, (command, group) in PRODUCTS.items():
        with tempfile.TemporaryDirectory() as tmp:
            good = Path(tmp) / f"{product}.h5"
            r = fkev(*command, "-o", good)
            if r.returncode != 0:
                t.add("product runs failed")
                t.notes.append(f"{product}: {r.stderr.strip()[-300:]}")
                continue
            for name, offset in _value_offsets(good, group).items():
                bad = Path(tmp) / "bad.h5"
                shutil.copyfile(good, bad)
                with open(bad, "r+b") as fh:
                    fh.seek(offset)
                    b = fh.read(1)
                    fh.seek(offset)
                    fh.write(bytes([b[0] ^ 0x10]))
                before = bad.read_bytes()
                t.add(f"{product}: byte changes")
                if verify(bad).ok:
                    t.add("damaged archives undetected by verify")
                    t.notes.append(f"{product} {name}: verify ok")
                resumed = fkev(*command, "-o", bad, "--resume")
                if resumed.returncode != 2 or bad.read_bytes() != before or "Traceback" in resumed.stderr:
                    t.add("damaged archives accepted by --resume")
                    t.notes.append(f"{product} {name}: resume exit {resumed.returncode}")
                with warnings.catch_warnings(record=True) as seen:
                    warnings.simplefilter("always")
                    try:
                        _reader(product)(bad)
                    except Exception as exc:  # noqa: BLE001 - a reader's refusal is fine, a crash is counted
                        t.notes.append(f"{product} {name}: reader raised {type(exc).__name__}")
                        t.add("reader exceptions")
                if not any(issubclass(w.category, DamagedArchiveWarning) for w in seen):
                    t.add("damaged archives read without a warning")
                    t.notes.append(f"{product} {name}: no warning")
                with warnings.catch_warnings(record=True) as seen:
                    warnings.simplefilter("always")
                    try:
                        open_dataset(bad, group=group)
                    except Exception as exc:  # noqa: BLE001 - counted like the readers'
                        t.notes.append(f"{product} {name}: open_dataset raised {type(exc).__name__}")
                        t.add("xarray read exceptions")
                if not any(issubclass(w.category, DamagedArchiveWarning) for w in seen):
                    t.add("damaged archives read by open_dataset without a warning")
                    t.notes.append(f"{product} {name}: open_dataset gave no warning")
    with tempfile.TemporaryDirectory() as tmp:
        r = fkev("design", BW, "--set", "links[1].elements=1,30", "--angles", "0", "--speeds", "100", "--cases", "full",
                 "--solver", "slepc", "-q", "-o", Path(tmp) / "d.h5", "-fkev_pep_max_it", "1")
        summary = r.stdout.split("design check at")[0].splitlines()  # the minima table, not the design check's
        rows = [ln for ln in summary if ln.split()[:1] in (["1"], ["30"])]
        flagged = (r.returncode == 3 and len(rows) == 2 and "no minima" in rows[1] and "no minima" not in rows[0]
                   and "Traceback" not in r.stderr)
        t.add("design points failing in their solve flagged (exit 3, no minima)" if flagged
              else "design points failing in their solve not flagged")
    return t
