"""``[materials.NAME]`` tables and ``material = "NAME"`` on links (docs/response.md §2).

A material gives a link (``[link_defaults]``, a ``[[links]]`` item, a ``[[links.segments]]``
item) its Young's modulus and density, and the design check its strengths. ``material`` and an
explicit ``youngs_modulus_pa``/``density_kg_m3`` in the same table are refused; across tables
the most specific one wins key by key, like every other link key (defaults → link → segment).
The shear modulus of out-of-plane torsion is a link's ``shear_modulus_pa``, else
G = E / 2(1 + ν) from its material's ``poisson_ratio`` and the link's E.
"""

from __future__ import annotations

from fkev_slepc.scene import shapes
from fkev_slepc.scene.model import Material
from fkev_slepc.scene.schema import REQUIRED, Reader, join, show

MATERIAL_KEY = "material"
SHEAR_KEY = "shear_modulus_pa"
# TOML key -> Material field; E and ρ are required, the rest optional
MATERIAL_PROPERTIES = {
    "youngs_modulus_pa": "youngs_modulus",
    "density_kg_m3": "density",
    "poisson_ratio": "poisson_ratio",
    "yield_pa": "yield_strength",
    "ultimate_pa": "ultimate_strength",
    "endurance_pa": "endurance_limit",
}
GIVEN = ("youngs_modulus_pa", "density_kg_m3")  # what ``material`` sets on a link
POISSON = (0.0, 0.5)  # 0 <= ν < 0.5 for an isotropic structural solid


def read_materials(r: Reader, doc) -> dict[str, Material] | None:
    """``[materials.NAME]``: name -> :class:`Material` of the valid entries, or ``None`` when
    ``[materials]`` itself is malformed (then no reference to a material is judged)."""
    table = r.table(doc, "materials", "")
    if table is None:
        return None
    out = {}
    for name, item in table.items():
        path = join("materials", name)
        if not isinstance(item, dict):
            r.add(path, f"must be a table [{path}] with youngs_modulus_pa, density_kg_m3, ... (got {show(item)})")
            continue
        r.check_keys(item, path, tuple(MATERIAL_PROPERTIES))
        values = {}
        for key, field_ in MATERIAL_PROPERTIES.items():
            limits = {"minimum": POISSON[0], "below": POISSON[1]} if key == "poisson_ratio" else {"positive": True}
            values[field_] = r.number(item, key, path, default=REQUIRED if key in GIVEN else None, **limits)
        ok = all(values[MATERIAL_PROPERTIES[k]] is not None for k in GIVEN)
        ok = ok and all(values[MATERIAL_PROPERTIES[k]] is not None for k in MATERIAL_PROPERTIES if k in item)
        ultimate = values["ultimate_strength"]
        for key in ("yield_pa", "endurance_pa"):
            value = values[MATERIAL_PROPERTIES[key]]
            if ultimate is not None and value is not None and value > ultimate:
                r.add(join(path, key), f"must be <= ultimate_pa = {show(item['ultimate_pa'])} (got {show(item[key])})")
                ok = False
        if ok:
            out[name] = Material(name=name, **values)
        else:
            out[name] = None  # known name, bad entry: references stay silent
    return out


def expand(r: Reader, table, path: str, materials: dict[str, Material | None] | None):
    """``table`` with its ``material`` (if any) turned into ``youngs_modulus_pa`` and
    ``density_kg_m3`` (the name stays under ``material``); problems are recorded on ``r`` with
    their dotted path (then the two keys are marked reported, see :func:`shapes.reported`)."""
    if not isinstance(table, dict) or MATERIAL_KEY not in table:
        return table
    out = dict(table)
    clash = [k for k in GIVEN if k in table]
    if clash:
        r.add(join(path, clash[0]), f"give {MATERIAL_KEY} = {show(table[MATERIAL_KEY])} or {'/'.join(GIVEN)}, not both")
        shapes.mark_reported(out, GIVEN)
        del out[MATERIAL_KEY]
        return out
    known = () if materials is None else tuple(materials)
    name = r.string(table, MATERIAL_KEY, path, choices=known, what="material") if materials is not None else None
    material = None if name is None else materials[name]
    if material is None:  # reported here, in [materials], or [materials] is malformed
        shapes.mark_reported(out, GIVEN)
        del out[MATERIAL_KEY]
        return out
    out["youngs_modulus_pa"], out["density_kg_m3"] = material.youngs_modulus, material.density
    return out


def shear_modulus(values: dict, materials: dict[str, Material | None] | None) -> float | None:
    """G of a table of link values: its ``shear_modulus_pa``, else E / 2(1 + ν) from its
    material's Poisson ratio and its E, else None."""
    if values.get(SHEAR_KEY) is not None:
        return values[SHEAR_KEY]
    material = (materials or {}).get(values.get(MATERIAL_KEY))
    e_mod = values.get("youngs_modulus_pa")
    if material is None or material.poisson_ratio is None or e_mod is None:
        return None
    return e_mod / (2.0 * (1.0 + material.poisson_ratio))


def poisson(values: dict, materials: dict[str, Material | None] | None) -> float | None:
    """ν of a table of link values: its material's Poisson ratio, else E/2G − 1 from an explicit
    ``shear_modulus_pa`` and its E, else None (Cowper's shear coefficient, docs/theory.md §22.1)."""
    material = (materials or {}).get(values.get(MATERIAL_KEY))
    if material is not None and material.poisson_ratio is not None:
        return material.poisson_ratio
    g, e_mod = values.get(SHEAR_KEY), values.get("youngs_modulus_pa")
    return None if g is None or e_mod is None else e_mod / (2.0 * g) - 1.0
