"""Writing one preset into a user's materials file, keeping the file's comments, order and
spelling of untouched values (tomlkit, from the `app` extra), atomically; never the shipped file."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from dentdemo import outputs
from dentdemo.errors import ConfigError, DentdemoError
from dentdemo.extras import require_app
from dentdemo.model.materials import (
    Calibration,
    Material,
    builtin_materials_path,
    parse_material,
)
from dentdemo.model.validate import TOML_MAX, read_input


def save_preset(path: Path, name: str, table: dict[str, Any], calibration: Calibration) -> Path:
    """Write `[materials.NAME]` = `table` into `path` (created if absent): keys whose value
    changed are rewritten in place (an inline comment kept), new keys appended unless they hold
    the default an absent key has, keys the table lacks removed; the rest of the file is left as
    it was. The result is checked as a start-up would check it before the file is replaced; a
    malformed file is one error and stays as it is."""
    require_app("saving materials", "tomlkit")
    import tomlkit
    from tomlkit.exceptions import TOMLKitError

    if path.resolve() == builtin_materials_path().resolve():
        raise DentdemoError(
            f"{path}: the shipped presets are never written; save to a file of your own "
            "(dentdemo demo --materials FILE)"
        )
    preset = parse_material(str(path), name, table, calibration)  # nothing invalid is written
    try:
        text = read_input(path, TOML_MAX).decode("utf-8") if path.exists() else ""
        doc = tomlkit.parse(text)
    except OSError as exc:  # a FIFO (never opened: it would freeze the window), a device
        raise ConfigError(str(path), "", f"cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), "", f"cannot read: {exc}") from None
    except TOMLKitError as exc:
        raise ConfigError(str(path), "", f"malformed TOML: {exc}") from None
    if "materials" not in doc:
        doc["materials"] = tomlkit.table(is_super_table=True)
    materials = doc["materials"]
    if name not in materials:
        materials[name] = tomlkit.table()
    target = materials[name]
    for key in [k for k in target if k not in table]:
        del target[key]
    for key, value in table.items():
        if key in target and target[key] == value:
            continue
        if key not in target and _implied(key, table, preset, calibration):
            continue  # absent means the same (a default): the file stays as it is
        item = tomlkit.item(_plain(value))
        if key in target:  # keep the line's comment
            old = target.item(key)
            item.trivia.comment, item.trivia.comment_ws = old.trivia.comment, old.trivia.comment_ws
        target[key] = item
    out = tomlkit.dumps(doc)
    tomllib.loads(out)  # tomlkit wrote TOML: a failure here is a bug, never a half file
    return outputs.write_text(path, out)


def _implied(key: str, table: dict[str, Any], preset: Material, calibration: Calibration) -> bool:
    """Whether the table without `key` makes the same preset (the key holds its default)."""
    rest = {k: v for k, v in table.items() if k != key}
    try:
        return parse_material("", preset.name, rest, calibration) == preset
    except DentdemoError:
        return False  # a required key


def _plain(value: Any) -> Any:
    """A float as TOML spells it shortest (2e+11, not 200000000000.0); other values as they are."""
    if isinstance(value, float):
        import tomlkit

        text = f"{value:.12g}"
        return tomlkit.value(text if any(c in text for c in ".en") else f"{text}.0")
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value
