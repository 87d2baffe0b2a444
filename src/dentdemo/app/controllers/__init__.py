"""The demo's features, one controller each, driven without a window: hot reload, the material
editor, saved state, undo and repair, glTF export, selection and the mouse's tools, video
recording, and the view. Each owns its state and its keys (`keys()`: a key's name, as
`DemoController.press` takes it, to its action); `DemoController` coordinates them."""

from __future__ import annotations

from collections.abc import Callable

#: A controller's keys: name ("space", "f5", "ctrl+z", "1") -> action.
Keys = dict[str, Callable[[], object]]
