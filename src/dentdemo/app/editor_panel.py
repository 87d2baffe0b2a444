"""The material editor's imgui window: every key of one preset with its unit and valid range
(from model/materials_keys.py, the validator's own table), k and Y as they follow, the dent the
panel's throw would leave in each plate material, and "save to file". The logic is the
controller's (app/controllers/editor.py); this only draws it."""

from __future__ import annotations

from typing import Any

from dentdemo.app.controller import DemoController
from dentdemo.model.materials import SURFACES, Appearance
from dentdemo.model.materials_keys import MATERIAL_NUMBERS

#: The window's width and its margin from the screen's top right corner, pixels.
WIDTH = 470
MARGIN = 10
ERROR_RED = (1.0, 0.45, 0.4, 1.0)


def editor_window(imgui: Any, app: DemoController) -> None:
    """Draw the editor window (imgui-bundle's `imgui` module) for `app`."""
    editor = app.editor.material
    screen_width = imgui.get_io().display_size.x
    imgui.set_next_window_pos((screen_width - WIDTH - MARGIN, MARGIN), imgui.Cond_.first_use_ever)
    imgui.set_next_window_size((WIDTH, 0), imgui.Cond_.first_use_ever)
    imgui.begin("material editor")
    imgui.push_item_width(170)
    names = app.sim.materials.names()
    changed, index = imgui.combo("preset", names.index(editor.name), names)
    if changed:
        editor.select(app.sim.materials, names[index])
    draft = editor.draft
    for spec in MATERIAL_NUMBERS:
        label = f"{spec.key}  {spec.range_text()}"
        if spec.optional:
            changed, checked = imgui.checkbox(f"set {spec.key}", spec.key in draft)
            if changed:
                app.editor.edit(
                    spec.key, getattr(editor.preset, spec.attribute) if checked else None
                )
            if spec.key not in draft:
                continue
        value = float(draft.get(spec.key, spec.default or 0.0))
        changed, value = imgui.input_double(label, value, 0.0, 0.0, "%.6g")
        if changed:
            app.editor.edit(spec.key, value)
        imgui.set_item_tooltip(f"unit: {spec.unit}; valid: {spec.range_text()}")
    changed, colour = imgui.color_edit3(
        "base_colour  linear RGB [0, 1]", list(draft["base_colour"])
    )
    if changed:
        app.editor.edit("base_colour", [float(c) for c in colour])
    coat = draft.get("coat_colour", list(Appearance().coat_colour))
    changed, colour = imgui.color_edit3("coat_colour  linear RGB [0, 1]", list(coat))
    if changed:
        app.editor.edit("coat_colour", [float(c) for c in colour])
    changed, index = imgui.combo("surface", SURFACES.index(draft["surface"]), list(SURFACES))
    if changed:
        app.editor.edit("surface", SURFACES[index])
    changed, text = imgui.input_text("source", draft["source"])
    if changed:
        app.editor.edit("source", text)
    imgui.pop_item_width()
    preset = editor.preset
    how = "set" if preset.k_explicit else "from E and P"
    imgui.text(f"k = {preset.k:.4g} m/(N*s) ({how})   Y = {preset.Y:.4g} N*s")
    if editor.error:
        imgui.text_colored(ERROR_RED, editor.error)
    if imgui.button("save to file"):
        app.editor.save()
    imgui.separator()
    p = app.panel
    dents = app.editor.predicted_dents()
    imgui.text(f"a {p.ball_material} ball, r {p.ball_radius * 1e3:.0f} mm, thrown straight down")
    imgui.text(
        f"at {p.throw_speed:.1f} m/s (eqs. 2-5): j = {dents[0].j_elastic:.3g} N*s, "
        f"ball dent {dents[0].ball_m * 1e3:.3f} mm{' (its bound)' if dents[0].ball_bound else ''}"
    )
    if imgui.begin_table("dents", 2):
        imgui.table_setup_column("plate material")
        imgui.table_setup_column("plate dent, mm")
        imgui.table_headers_row()
        for dent in dents:
            imgui.table_next_row()
            imgui.table_set_column_index(0)
            imgui.text(dent.plate_material)
            imgui.table_set_column_index(1)
            bound = " (bound: its material or 2 cm plate)" if dent.plate_bound else ""
            imgui.text(f"{dent.plate_m * 1e3:.3f}{bound}")
        imgui.end_table()
    imgui.end()
