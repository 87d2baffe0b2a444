"""The package as a user installs it: the built wheel carries every shipped file, and installed
outside the checkout without the `app` extra it runs the example host, `indent` and every shipped
scene, while the commands that need the extra say which one in one line.

The wheel is built once for the module. The install is a fresh virtual environment (no pip of its
own, so it takes a second) that sees only the wheel's core requirements, linked in from this
test environment's site-packages (computed from the wheel's own metadata, so a dependency moved
between the core and the extra is seen), with the wheel installed into it by pip. A real
`pip install .` that resolves the dependencies from the registry is scripts/check-core-install.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from email.parser import Parser
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

#: Builds a wheel and a virtual environment: `./scripts/test -m "not install"` leaves it out.
pytestmark = [pytest.mark.install, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[1]
#: What the wheel must carry beside the code, as (folder in the repository, folder in the wheel).
SHIPPED = (("shaders", "dentdemo/shaders"), ("assets", "dentdemo/assets"))
#: The `app` extra's modules: none may be importable in the core install.
APP_MODULES = ("glfw", "imgui_bundle", "imageio_ffmpeg", "tqdm", "tomlkit")


def _run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(command, capture_output=True, text=True, timeout=600, **kwargs)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of the checkout (without build/, whose stale files
    setuptools would otherwise put into the wheel)."""
    tmp = tmp_path_factory.mktemp("wheel")
    source = tmp / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            "build", "dist", ".venv", ".git", "*.egg-info", "__pycache__", ".*cache", ".tools"
        ),
    )
    built = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp), str(source)]
    )
    assert built.returncode == 0, built.stderr[-2000:]
    return next(tmp.glob("dentdemo-*.whl"))


def _core_requirements(wheel: Path) -> set[str]:
    """Distribution names the wheel requires without any extra, and what they require in turn
    (as installed here), lower-case."""
    with zipfile.ZipFile(wheel) as archive:
        name = next(n for n in archive.namelist() if n.endswith(".dist-info/METADATA"))
        metadata = Parser().parsestr(archive.read(name).decode())
    pending = [r for r in metadata.get_all("Requires-Dist") or [] if "extra ==" not in r]
    found: set[str] = set()
    while pending:
        requirement = pending.pop()
        if "extra ==" in requirement:
            continue
        match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement)
        assert match, requirement
        dist_name = match.group(1).lower().replace("_", "-")
        if dist_name in found:
            continue
        try:
            dist = importlib.metadata.distribution(dist_name)
        except importlib.metadata.PackageNotFoundError:
            continue  # a requirement for another platform or Python, not installed here
        found.add(dist_name)
        pending += dist.requires or []
    return found


@pytest.fixture(scope="module")
def core(wheel, tmp_path_factory) -> dict:
    """A virtual environment with the wheel and its core requirements only; returns its python,
    its `dentdemo` command, the installed package folder and an environment to run them in."""
    tmp = tmp_path_factory.mktemp("core")
    venv = tmp / "venv"
    made = _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    assert made.returncode == 0, made.stderr
    python = venv / "bin" / "python"
    site = Path(
        _run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"]
        ).stdout.strip()
    )
    here = Path(sysconfig.get_path("purelib"))
    for name in _core_requirements(wheel):
        dist = importlib.metadata.distribution(name)
        tops = {Path(str(f)).parts[0] for f in dist.files or [] if not str(f).startswith("..")}
        for top in tops:
            if (here / top).exists() and not (site / top).exists():
                (site / top).symlink_to(here / top)
    installed = _run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(python),
            "install",
            "--no-deps",
            "--no-index",
            "-q",
            str(wheel),
        ]
    )
    assert installed.returncode == 0, installed.stderr[-2000:]
    env = {
        "PATH": f"{venv / 'bin'}:/usr/bin:/bin",
        "HOME": str(tmp),
        "DENTDEMO_GL_BACKEND": "egl",
    }
    return {
        "python": str(python),
        "dentdemo": str(venv / "bin" / "dentdemo"),
        "package": site / "dentdemo",
        "env": env,
        "cwd": tmp,
    }


def _in_core(core: dict, *args: str) -> subprocess.CompletedProcess:
    """Run a command in the core install, outside the checkout, with no display."""
    return _run(list(args), env=core["env"], cwd=core["cwd"])


def test_wheel_carries_every_shipped_file(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = [
        (path, f"{inside}/{path.relative_to(ROOT / folder).as_posix()}")
        for folder, inside in SHIPPED
        for path in (ROOT / folder).rglob("*")
        if path.is_file() and "__pycache__" not in path.parts
    ]
    assert len(shipped) > 40  # shaders, materials, scenes, meshes with their MTL and PNG
    missing = [name for _, name in shipped if name not in names]
    assert missing == []
    for module in (ROOT / "src" / "dentdemo").rglob("*.py"):
        assert f"dentdemo/{module.relative_to(ROOT / 'src' / 'dentdemo').as_posix()}" in names
    assert "dentdemo/py.typed" in names


def test_type_checker_reads_the_installed_package_types(core, tmp_path):
    """A host type-checked against the installed wheel (py.typed): the exports have their real
    types, and a wrong call is caught."""
    host = tmp_path / "host.py"
    lines = ["import dentdemo", "reveal_type(dentdemo.Carver.press)", "dentdemo.Sphere('5 cm')"]
    host.write_text("\n".join(lines) + "\n")
    checked = _run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--python-executable",
            core["python"],
            "--no-incremental",
            "--follow-imports=silent",
            str(host),
        ],
        cwd=tmp_path,
    )
    assert "def (self: dentdemo.api.Carver, target: dentdemo.api.DentableSurface" in checked.stdout
    assert 'Argument 1 to "Sphere" has incompatible type "str"' in checked.stdout, checked.stdout
    assert "missing library stubs or py.typed" not in checked.stdout


def test_core_install_has_no_app_extra(core):
    probe = "import importlib.util as u, sys; print([m for m in sys.argv[1:] if u.find_spec(m)])"
    found = _in_core(core, core["python"], "-c", probe, *APP_MODULES)
    assert found.returncode == 0, found.stderr
    assert found.stdout.strip() == "[]"


def test_core_install_runs_indent(core, tmp_path):
    out = tmp_path / "press"
    done = _in_core(
        core, core["dentdemo"], "indent", "--depth", "0.005", "--map-size", "128", "--out", out
    )
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cap"]["rms_error_rel"] < 0.02


def test_core_install_runs_the_example_host(core, tmp_path):
    example = tmp_path / "carve_in_your_context.py"
    shutil.copy(ROOT / "examples" / example.name, example)
    image, glb = tmp_path / "dent.png", tmp_path / "torus.glb"
    done = _in_core(core, core["python"], str(example), "--out", str(image), "--gltf", str(glb))
    assert done.returncode == 0, done.stderr[-2000:]
    assert "'pressed': True" in done.stdout
    assert Image.open(image).size == (480, 360)
    assert glb.read_bytes()[:4] == b"glTF"  # the API's export: library side, no extra


def test_core_install_demo_names_the_missing_extra(core):
    done = _in_core(core, core["dentdemo"], "demo")
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "glfw" in lines[0] and "imgui-bundle" in lines[0]
    assert "pip install 'dentdemo[app]'" in lines[0]
    assert not (core["cwd"] / "dentdemo_demo.png").exists()


def test_core_install_bench_window_names_the_missing_extra(core):
    done = _in_core(core, core["dentdemo"], "bench", "--tiny", "--window")
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "'dentdemo[app]'" in lines[0] and "glfw" in lines[0], done.stderr


def test_core_install_mp4_names_the_missing_extra_before_any_work(core, tmp_path):
    png, clip = tmp_path / "last.png", tmp_path / "clip.mp4"
    done = _in_core(
        core, core["dentdemo"], "render", "--frames", "2", "--out", str(png), "--video", str(clip)
    )
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "imageio-ffmpeg" in lines[0], done.stderr
    assert "'dentdemo[app]'" in lines[0]
    assert not png.exists() and not clip.exists()


def test_core_install_runs_every_shipped_scene(core, tmp_path):
    """Every scene the package ships, loaded from the installed package (its meshes, their
    materials and textures included), simulated and drawn for a few frames."""
    installed = sorted(p.name for p in (core["package"] / "assets" / "scenes").glob("*.toml"))
    assert installed == sorted(p.name for p in (ROOT / "assets" / "scenes").glob("*.toml"))
    code = (
        "import sys, pathlib\n"
        "from dentdemo.cli import main\n"
        "from dentdemo.resources import assets_dir\n"
        "assert str(assets_dir()).startswith(sys.argv[1]), assets_dir()\n"
        "for scene in sorted((assets_dir() / 'scenes').glob('*.toml')):\n"
        "    out = pathlib.Path(sys.argv[2]) / (scene.stem + '.png')\n"
        "    code = main(['render', '--scene', str(scene), '--frames', '3', '--size', '96x64',\n"
        "                 '--out', str(out)])\n"
        "    if code:\n"
        "        sys.exit(f'{scene.name}: exit {code}')\n"
    )
    done = _in_core(core, core["python"], "-I", "-c", code, str(core["package"]), str(tmp_path))
    assert done.returncode == 0, done.stderr[-2000:]
    for name in installed:
        pixels = np.asarray(Image.open(tmp_path / name.replace(".toml", ".png")))
        assert pixels.shape == (64, 96, 3)
        assert pixels.std() > 5, name  # a drawn scene, not a blank frame
    assert os.path.isdir(core["package"] / "assets" / "meshes")


def test_progress_bar_is_silently_skipped_without_tqdm(monkeypatch):
    from dentdemo import progress

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert progress.progress_bar(3, "frames") is not None  # tqdm is here (the app extra)
    monkeypatch.setitem(sys.modules, "tqdm", None)  # import tqdm now raises ImportError
    assert progress.progress_bar(3, "frames") is None


def test_require_app_names_the_extra_and_the_packages(monkeypatch):
    from dentdemo import extras
    from dentdemo.errors import MissingExtraError

    extras.require_app("the demo", "glfw", "imgui_bundle")  # installed here: no error
    monkeypatch.setattr(extras, "installed", lambda module: module != "imgui_bundle")
    with pytest.raises(MissingExtraError) as caught:
        extras.require_app("the demo", "glfw", "imgui_bundle")
    assert str(caught.value) == (
        "dentdemo: the demo needs imgui-bundle, from the 'app' extra: pip install 'dentdemo[app]'"
    )
