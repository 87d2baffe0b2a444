"""`dentdemo materials`: the effective material presets with their derived k and Y."""

from __future__ import annotations

import argparse
import json

from dentdemo.cli.args import add_materials, command


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "materials",
        "list the effective material presets with k and Y",
        "dentdemo materials --materials my_metals.toml --json",
    )
    add_materials(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.model.materials import load_materials

    library = load_materials(args.materials)
    if args.json:
        payload = {
            "sources": list(library.sources),
            "calibration": {
                "k_per_compliance": library.calibration.k_per_compliance,
                "Y_unit_Ns": library.calibration.Y_unit,
            },
            "materials": [library.materials[n].as_dict() for n in library.names()],
        }
        print(json.dumps(payload, indent=2))
        return 0
    header = f"{'name':<11} {'E (GPa)':>8} {'P (GPa)':>8} {'rho':>6} {'eps':>5} {'mu':>4} "
    header += f"{'C_rr':>6} {'K wear':>7} {'H (GPa)':>7} "
    header += f"{'max (mm)':>8} {'k (m/Ns)':>10} {'Y (Ns)':>7}"
    print(header)
    for name in library.names():
        m = library.materials[name]
        tag = "*" if m.k_explicit else " "
        print(
            f"{name:<11} {m.youngs_modulus / 1e9:8.3g} {m.plastic_modulus / 1e9:8.3g} "
            f"{m.density:6.0f} {m.restitution:5.2f} {m.friction:4.2f} "
            f"{m.rolling_friction:6.4g} {m.wear_coefficient:7.2g} {m.hardness / 1e9:7.3g} "
            f"{m.max_dent_depth * 1e3:8.1f} "
            f"{m.k:10.3g}{tag}{m.Y:7.3g}"
        )
    print("(* k set by the preset; otherwise k = k_per_compliance * (1/P - 1/E))")
    for name in library.names():
        m = library.materials[name]
        if m.appearance.coat_thickness > 0:
            own = "" if m.coat_wear_explicit or m.coat_hardness_explicit else " (the material's)"
            print(
                f"{name}: a coat {m.appearance.coat_thickness * 1e3:.3g} mm thick, wearing with "
                f"K {m.coat_wear_coefficient:.2g}, H {m.coat_hardness / 1e9:.3g} GPa{own}"
            )
    return 0
