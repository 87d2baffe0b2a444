"""The developer tools' imgui window, after G3D's: the selected body (Ctrl + click) with its
dents, a live view of its height and normal maps, the profiler strip, and the video recorder.
The logic is the controllers' (app/controllers/tools.py and recording.py)."""

from __future__ import annotations

from typing import Any

from dentdemo.app.controller import DemoController
from dentdemo.app.profiler import HISTORY_SECONDS, PHASES

#: The window's size, pixels; it opens at the bottom of the screen, right of the main panel
#: (LEFT pixels from the left edge), between it and the material editor at 1280 x 720.
WIDTH, HEIGHT = 330, 425
LEFT = 460
MARGIN = 10
#: Side of each map's image in the window, pixels.
MAP_PIXELS = 150
#: Height of each profiler plot, pixels.
PLOT_PIXELS = 22


def dev_window(imgui: Any, app: DemoController) -> None:
    """Draw the developer tools window (imgui-bundle's `imgui` module) for `app`."""
    height = imgui.get_io().display_size.y
    imgui.set_next_window_pos((LEFT, height - MARGIN), imgui.Cond_.first_use_ever, (0.0, 1.0))
    imgui.set_next_window_size((WIDTH, HEIGHT), imgui.Cond_.first_use_ever)
    imgui.begin("developer tools")
    tools = app.tools
    for line in tools.selection_text():
        imgui.text(line)
    textures = tools.map_textures()
    if textures is not None:
        # Row 0 of a GL texture is v = 0: shown bottom up, so v = 1 is at the top.
        for texture in textures:
            imgui.image(imgui.ImTextureRef(texture.glo), (MAP_PIXELS, MAP_PIXELS), (0, 1), (1, 0))
            imgui.same_line()
        imgui.new_line()
        depth_mm = app.view.options.legend_depth * 1e3
        imgui.text(f"height (grey 0 to red {depth_mm:g} mm), normals")
    imgui.separator()
    imgui.text(f"ms per frame, the last {HISTORY_SECONDS:g} s (GPU time shows")
    imgui.text("in present: the swap waits for it)")
    for phase in PHASES:
        values = tools.profiler.series(phase)
        if len(values):
            overlay = f"{phase} {tools.profiler.mean(phase):.2f} ms"
            imgui.plot_lines(
                f"##{phase}", values, 0, overlay, 0.0, graph_size=(WIDTH - 20, PLOT_PIXELS)
            )
    imgui.separator()
    recorder = app.recording.recorder
    if imgui.button("stop recording (F6)" if recorder is not None else "record video (F6)"):
        app.recording.toggle()
    if recorder is not None:
        imgui.same_line()
        imgui.text(f"{recorder.out}: {recorder.frames} frames")
    imgui.end()
