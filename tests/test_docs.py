"""The README and docs/ link only files that exist inside the repository; the README fits on a
few screens and covers every command; the version is pyproject.toml's everywhere; code comments
keep reasons, not timings."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import dentdemo
from dentdemo.cli import COMMANDS

ROOT = Path(__file__).resolve().parents[1]


def test_readme_and_docs_link_files_inside_the_repository():
    pages = [ROOT / name for name in ("README.md", "CHANGELOG.md", "DEVELOPERS.md")]
    pages += sorted((ROOT / "docs").glob("*.md"))
    checked = 0
    for page in pages:
        text = page.read_text()
        for target in re.findall(r"\]\(([^)#\s]+)\)", text):
            if re.match(r"[a-z]+://", target):
                continue
            path = (page.parent / target).resolve()
            assert path.is_relative_to(ROOT), f"{page.name} links outside the repo: {target}"
            assert path.exists(), f"{page.name} links a missing file: {target}"
            checked += 1
        assert "../shared" not in text, f"{page.name} points outside the repository"
    assert checked >= 5


def test_the_readme_fits_and_covers_every_command():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 400
    assert "./scripts/demo" in text and "./scripts/test" in text
    for heading in ("## Commands", "## Use it in your own program", "## File formats"):
        assert f"\n{heading}\n" in text, heading
    for module in COMMANDS:
        name = module.__name__.rsplit(".", 1)[-1]
        assert f"| `dentdemo {name}" in text, f"the commands table lacks {name}"


def test_the_version_is_pyprojects_everywhere():
    """`dentdemo --version`, `dentdemo.__version__` and the changelog's newest release all say
    the version written in pyproject.toml."""
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    out = subprocess.run(
        [sys.executable, "-m", "dentdemo", "--version"], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == f"dentdemo {version}", "stale install: run ./scripts/test"
    # The installed metadata is the install's: ./scripts/test reinstalls when pyproject changes.
    assert dentdemo.__version__ == version, "stale install: run ./scripts/test"
    releases = re.findall(
        r"^## \[(\d[^\]]*)\] - \d{4}-\d{2}-\d{2}$", (ROOT / "CHANGELOG.md").read_text(), re.M
    )
    assert releases[0] == version


#: A timing in prose: a number (or a range) of ms, µs, us or ns, not part of a name (`p90 ms`).
TIMING = re.compile(r"(?<![\w.])\d+(\.\d+)?([-–]\d+(\.\d+)?)?\s?(ms|µs|us|ns)\b")


def test_code_comments_keep_reasons_not_timings():
    """Measurements go stale in code; docs/performance.md keeps the current ones."""
    sources = [*(ROOT / "src" / "dentdemo").rglob("*.py"), *(ROOT / "shaders").rglob("*.*")]
    found = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in sources
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if TIMING.search(line)
    ]
    assert found == []
