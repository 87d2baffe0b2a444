"""Every bad input gets one clear stderr line (naming the file, key or flag and the value), a
non-zero exit, no traceback and nothing written; borderline inputs that are reasonable are
accepted with their effect checked. The table is tests/bad_input_cases.py."""

from __future__ import annotations

import os
import subprocess
import sys
import traceback
from collections import Counter
from pathlib import Path

import pytest

from bad_input_cases import Case, all_cases
from dentdemo.cli import main

CASES = all_cases()
AREAS = ("scene", "mesh", "bump", "materials", "flags", "env")


def test_the_table_covers_every_area_with_enough_cases():
    per_area = Counter(case.area for case in CASES)
    assert set(per_area) == set(AREAS), per_area
    assert sum(per_area.values()) >= 120, per_area
    assert min(per_area.values()) >= 8, per_area
    assert len({case.id for case in CASES}) == len(CASES)
    assert SLOW_CASES <= {case.id for case in CASES}


def _files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _run(case: Case, folder: Path, monkeypatch, capsys) -> tuple[int, str, str]:
    argv = [arg.replace("{d}", str(folder)) for arg in case.argv]
    # In a process of its own: what the interpreter reads at start (PYTHON*), and GLX, whose
    # X connection is the process's own native state (after another test's GL work in the same
    # process, Xlib ends the process on a bad display instead of failing the call).
    fresh = case.env.get("DENTDEMO_GL_BACKEND") == "glx"
    if fresh or any(key.startswith("PYTHON") for key in case.env):
        env = {**os.environ}
        for key, value in case.env.items():
            env.pop(key, None) if value is None else env.__setitem__(key, value)
        done = subprocess.run(
            [sys.executable, "-m", "dentdemo", *argv],
            capture_output=True,
            text=True,
            cwd=folder,
            env=env,
            timeout=300,
        )
        return done.returncode, done.stdout, done.stderr
    monkeypatch.chdir(folder)
    for key, value in case.env.items():
        if value is None:
            monkeypatch.delenv(key, raising=False)
        else:
            monkeypatch.setenv(key, value)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:  # noqa: BLE001 - a traceback is exactly what the case forbids
        pytest.fail(f"{case.id}: uncaught exception\n{traceback.format_exc()}")
    out, err = capsys.readouterr()
    return code, out, err


#: The cases that run a whole command (a render, a demo until its screenshot): `slow`.
SLOW_CASES = {
    "flags-demo_screenshot_alone_ends_after_3_s",
    "env-warnings_as_errors_still_one_line",
    "flags-render_literal_percent_accepted",
    "flags-render_pattern_with_literal_percent_accepted",
    "flags-render_accepted",
    "bump-rgba_white_is_the_bump_height",
    "bump-8bit_white_is_the_bump_height",
    "flags-save_state_replaces_an_earlier_state_whole",
    "bump-16bit_white_is_the_bump_height",
    "flags-load_state_missing",
    "flags-press_misses",
}


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(case, id=case.id, marks=pytest.mark.slow if case.id in SLOW_CASES else ())
        for case in CASES
    ],
)
def test_bad_input(case: Case, tmp_path, monkeypatch, capsys):
    folder = tmp_path / "case"
    folder.mkdir()
    for name, content in case.files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
    before = _files_under(folder)
    code, out, err = _run(case, folder, monkeypatch, capsys)
    assert "Traceback" not in err, err
    if case.reject is not None:
        lines = err.strip().splitlines()
        assert code != 0, f"accepted: {out[-400:]}"
        assert len(lines) == 1, f"expected one stderr line, got:\n{err}"
        for fragment in case.reject:
            assert fragment in lines[0], f"{fragment!r} not in: {lines[0]}"
        assert _files_under(folder) == before, "output left behind"
    else:
        assert code == 0, err
        assert case.accept is not None
        case.accept(out, err, folder)
