"""Issue 46: every file in and out under faults. Outputs that are devices, FIFOs or sockets, in
folders that cannot be written, on a full disk; leftovers of killed writers; inputs that never
end or block; saved states that hold nonsense. Device nodes, read-only folders and full disks
live in a private mount namespace (tests/faults_helpers.py), never on the machine's own /dev."""

from __future__ import annotations

import fcntl
import json
import os
import random
import shutil
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from cli_helpers import dentdemo, python_json
from dentdemo.cli import main
from faults_helpers import dentdemo_line, in_namespace, needs_namespace, results, separated

RENDER = ["render", "--frames", "2", "--size", "32x18"]


def _kind(path: Path) -> str:
    mode = path.lstat().st_mode
    for test, name in ((stat.S_ISCHR, "chr"), (stat.S_ISFIFO, "fifo"), (stat.S_ISSOCK, "sock")):
        if test(mode):
            return name
    return "file" if stat.S_ISREG(mode) else "other"


@needs_namespace
@pytest.mark.slow
def test_render_over_a_device_node_leaves_the_device_and_exits_1(tmp_path):
    """`render --out /dev/null` renamed a 1,068-byte PNG over /dev/null as root. Here the nodes
    are made in a tmpfs of a private namespace: null, full, and a link to null named .png."""
    d = tmp_path / "dev"
    d.mkdir()
    setup = [
        f"mount -t tmpfs -o size=1m none {d}",
        f"mknod {d}/null c 1 3",
        f"mknod {d}/full c 1 7",
        f"ln -s {d}/null {d}/link.png",
    ]
    runs = [
        [*RENDER, "--out", d / "null"],
        [*RENDER, "--out", d / "full"],
        [*RENDER, "--out", d / "link.png"],
        [*RENDER, "--out", tmp_path / "r.png", "--video", d / "null"],
        [*RENDER, "--out", tmp_path / "r.png", "--gltf", d / "link.png"],
        ["indent", "--depth", "0.001", "--map-size", "32", "--out", d / "null"],
        [
            "indent",
            "--depth",
            "0.001",
            "--map-size",
            "32",
            "--out",
            tmp_path / "i",
            "--render",
            d / "link.png",
        ],
    ]
    lines = [separated(dentdemo_line(*argv)) for argv in runs]
    lines += [f"stat -c %F {d}/null {d}/full {d}/link.png; stat -L -c %F {d}/link.png"]
    done = in_namespace(setup, lines, tmp_path)
    got = results(done)
    assert len(got) == len(runs), done.stderr
    for argv, (code, err) in zip(runs, got, strict=True):
        assert code == 1 and len(err) == 1, (argv, code, err)
        assert "character device, not a regular file" in err[0] or "is not a folder (it is a "
        "character device)" in err[0], (argv, err)
    kinds = done.stdout.splitlines()[-4:]
    assert kinds == ["character special file"] * 2 + ["symbolic link", "character special file"]
    assert not (tmp_path / "r.png").exists() and not (tmp_path / "i").exists()


def test_render_over_a_fifo_or_socket_refuses_in_one_line(tmp_path, monkeypatch, capsys):
    """A FIFO or a socket as an output (or the folder of --maps-dir) is refused before any
    work, and stays what it was."""
    monkeypatch.chdir(tmp_path)
    fifo = tmp_path / "f.png"
    os.mkfifo(fifo)
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(tmp_path / "s.png"))
    try:
        for argv, what in (
            ([*RENDER, "--out", "f.png"], "a FIFO"),
            ([*RENDER, "--out", "s.png"], "a socket"),
            ([*RENDER, "--out", "r.png", "--maps-dir", "f.png"], "a FIFO"),
            (["bench", "--tiny", "--plot", "s.png"], "a socket"),
        ):
            assert main([str(a) for a in argv]) == 1
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and what in err[0], err
        assert _kind(fifo) == "fifo" and _kind(tmp_path / "s.png") == "sock"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png", "s.png"]
    finally:
        sock.close()


@needs_namespace
@pytest.mark.slow
def test_outputs_in_a_folder_that_cannot_be_written_are_refused_before_any_work(tmp_path):
    """A read-only file system, /sys and /proc: every writer's folder is tried by making its
    temporary file (or folder) before any work. 100,000 frames or a whole
    bench would take many minutes: each refusal comes before them, in one line."""
    ro = tmp_path / "ro"
    ro.mkdir()
    setup = [f"mount -t tmpfs -o ro,size=1m none {ro}"]
    long = ["render", "--frames", "100000", "--size", "32x18", "--out"]
    runs = [
        [*long, ro / "r.png"],
        [*long, ro / "new" / "r.png"],
        [*long, tmp_path / "r.png", "--gltf", ro / "g.glb"],
        [*long, tmp_path / "r.png", "--maps-dir", ro],
        [*long, tmp_path / "r.png", "--maps-dir", ro / "maps"],
        [*long, tmp_path / "r.png", "--save-state", ro / "state"],
        [*long, tmp_path / "r.png", "--video", ro / "v.gif"],
        ["indent", "--depth", "0.001", "--map-size", "8192", "--out", ro / "press"],
        ["bench", "--quick", "--json", ro / "x" / "b.json"],
        # sysfs and procfs refuse new files to root, who passes os.access there: tried, not
        # assumed (nothing is created in them either way).
        [*long, "/sys/r.png"],
        [*long, "/proc/r.png"],
        [*long, tmp_path / "r.png", "--gltf", "/sys/g.glb"],
        [*long, tmp_path / "r.png", "--maps-dir", "/sys/kernel"],
        [*long, tmp_path / "r.png", "--save-state", "/proc/x"],
        ["bench", "--quick", "--json", "/sys/x/b.json"],
    ]
    lines = [separated(dentdemo_line(*argv)) for argv in runs]
    done = in_namespace(setup, lines, tmp_path, timeout=120)
    got = results(done)
    assert len(got) == len(runs), done.stderr
    for argv, (code, err) in zip(runs, got, strict=True):
        assert code == 1 and len(err) == 1, (argv, code, err)
        assert str(argv[-2]) in err[0], (argv, err)
        assert "not writable" in err[0] or "cannot write in folder" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro"]


def _fill(folder: Path, free_kib: int) -> str:
    """A shell line filling `folder`'s file system, then freeing `free_kib` KiB of it."""
    return (
        f"(dd if=/dev/zero of={folder}/fill bs=4k 2>/dev/null; true) && "
        f"truncate -s -{free_kib}K {folder}/fill"
    )


@needs_namespace
@pytest.mark.slow
def test_a_video_on_a_full_disk_keeps_the_old_file_and_exits_1(tmp_path):
    """An MP4 (and a GIF) whose disk fills while it is written: ffmpeg's "Error writing trailer"
    left an 8 kB file without its moov box over the good one, exit 0. Now the old file stays
    byte for byte, one line, exit 1, nothing hidden left; a disk full from the start is the
    same for a GIF (a 38-line OSError traceback before)."""
    full = tmp_path / "full"
    full.mkdir()
    good = tmp_path / "good"
    good.mkdir()
    for name in ("x.mp4", "x.gif"):
        done = main(["-q", *RENDER, "--out", str(good / "g.png"), "--video", str(good / name)])
        assert done == 0
    setup = [
        f"mount -t tmpfs -o size=2m none {full}",
        f"cp {good}/x.mp4 {good}/x.gif {full}/",
        _fill(full, 8),
    ]
    clip = ["render", "--frames", "30", "--size", "320x180", "--out", tmp_path / "o.png"]
    runs = [[*clip, "--video", full / "x.mp4"], [*clip, "--video", full / "x.gif"]]
    lines = [separated(dentdemo_line(*argv)) for argv in runs]
    lines.append(f"ls -A {full}; cmp {good}/x.mp4 {full}/x.mp4 && cmp {good}/x.gif {full}/x.gif")
    lines.append("echo same=$?")
    done = in_namespace(setup, lines, tmp_path)
    got = results(done)
    assert len(got) == 2, done.stderr
    for (code, err), name in zip(got, ("x.mp4", "x.gif"), strict=True):
        assert code == 1 and len(err) == 1, err
        assert err[0].startswith(f"--video: '{full / name}' not written (") and "replaced" in err[0]
    listing = done.stdout.split("rc=1\n")[-1].splitlines()
    assert listing[:-1] == ["fill", "x.gif", "x.mp4"] and listing[-1] == "same=0", done.stdout


def test_a_recording_without_frames_writes_nothing(gl, tmp_path, capsys):
    """F6 then Esc in one frame wrote a 261-byte MP4 without a stream, exit 0, and ffmpeg's
    unprefixed "No frames have been written". Now nothing is written, one line says so."""
    from dentdemo.app.controller import DemoController
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    root = Path(__file__).resolve().parents[1]
    app = DemoController(gl, load_scene(root / "assets/scenes/ball_drop.toml", lib), lib, (64, 36))
    target = tmp_path / "r.mp4"
    assert app.recording.toggle(target)
    app.close()  # Esc: the window closes the controller, which stops the recording
    assert sorted(tmp_path.iterdir()) == []
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"recording: '{target}' not written (no frames were recorded); nothing replaced"]
    assert app.message == err[0]


#: A writer of fake state folders, killed at random moments by the test below.
_SAVER = """
import sys
from pathlib import Path
from dentdemo import outputs
from dentdemo.outputs import write_folder
# Each saver leaves its predecessors' folders (as killed saves before this fix did), so that
# the kills pile them up: the save under test must remove them all.
outputs.remove_leftovers = lambda *args, **kwargs: []
files = {"state.json": b"{}" * 1000, "a.npy": bytes(4 << 20), "b.npy": bytes(4 << 20)}
print("ready", flush=True)
while True:
    write_folder(Path(sys.argv[1]), files)
"""


@pytest.mark.slow
def test_killed_saves_leave_folders_the_next_save_removes_and_a_load_keeps(tmp_path):
    """40 SIGKILLs during saves of S left `.S.<random>.new` folders (20 of them, 89 MB after 72
    kills) that nothing removed or mentioned. A load (refused here: the state is a fake) writes
    nothing and keeps them; the next save removes them and says so in one line."""

    state = tmp_path / "S"
    rng = random.Random(46)
    for _ in range(40):
        saver = subprocess.Popen(
            [sys.executable, "-c", _SAVER, str(state)], stdout=subprocess.PIPE, text=True
        )
        assert saver.stdout is not None and saver.stdout.readline() == "ready\n"
        time.sleep(rng.uniform(0.0, 0.08))
        saver.send_signal(signal.SIGKILL)
        saver.wait()
        saver.stdout.close()
    hidden = sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("."))
    assert hidden and all(name.startswith(".S.") and name.endswith(".new") for name in hidden)
    before = sorted(p.name for p in tmp_path.rglob("*"))

    load = dentdemo(*RENDER, "--out", tmp_path / "l.png", "--load-state", state, cwd=tmp_path)
    assert load.returncode == 1 and len(load.stderr.splitlines()) == 1, load.stderr
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # a load never writes
    save = dentdemo(*RENDER, "--out", tmp_path / "r.png", "--save-state", state, cwd=tmp_path)
    assert save.returncode == 0, save.stderr
    n = len(hidden)
    what = "leftover" if n == 1 else "leftovers"
    assert save.stderr.splitlines() == [
        f"dentdemo: --save-state: removed {n} {what} of an interrupted write of '{state}' "
        f"({', '.join(hidden[:3])}{', ...' if n > 3 else ''})"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["S", "r.png"]
    assert (state / "state.json").is_file()


@pytest.mark.slow
def test_a_killed_videos_file_is_removed_by_the_next_render_to_it(tmp_path, capsys):
    """`.v.mp4.<random>.mp4` of a killed video was never removed. The next render of v.mp4
    removes it (saying so), leaves a living writer's alone and touches no other hidden file."""

    dead = tmp_path / ".v.mp4.k2j4x9ab.mp4"
    dead.write_bytes(b"\0" * 1000)
    alive = tmp_path / ".v.mp4.abcdefgh.mp4"
    alive.write_bytes(b"\0" * 10)
    other = tmp_path / ".w.mp4.k2j4x9ab.mp4"  # another target's
    other.write_bytes(b"")
    with open(alive, "rb") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # as a living writer holds its file
        video = tmp_path / "v.mp4"
        assert main([*RENDER, "--out", str(tmp_path / "o.png"), "--video", str(video)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"dentdemo: --video: removed 1 leftover of an interrupted write of '{video}' ({dead.name})"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [alive.name, other.name, "o.png", "v.mp4"]
    )


@needs_namespace
@pytest.mark.slow
def test_endless_and_blocking_inputs_are_one_line_within_a_second(tmp_path):
    """/dev/zero (a device node of the test's own namespace; a link to it) and a FIFO as a
    scene, a materials file or a saved map: each was read until memory ran out (a MemoryError
    traceback) or blocked forever. Each is now one line, and each read is refused within a
    second."""

    d = tmp_path / "dev"
    d.mkdir()
    state = tmp_path / "S"
    done = dentdemo(
        "render",
        "--frames",
        "2",
        "--size",
        "32x18",
        "--out",
        tmp_path / "r.png",
        "--save-state",
        state,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    for name, replace in (("Szero", "zero"), ("Sfifo", "fifo")):
        shutil.copytree(state, tmp_path / name)
        plate = tmp_path / name / "steel_plate.npy"
        plate.unlink()
        if replace == "fifo":
            os.mkfifo(plate)
        else:
            plate.symlink_to(d / "zero")
    os.mkfifo(tmp_path / "fifo.toml")
    setup = [
        f"mount -t tmpfs -o size=1m none {d}",
        f"mknod {d}/zero c 1 5",
        f"ln -s {d}/zero {tmp_path}/zero.toml",
        "ulimit -v 8000000",  # the old reader's end: MemoryError at 8 GB, not the machine's
    ]
    render = ["render", "--frames", "1", "--size", "32x18", "--out", tmp_path / "x.png"]
    runs = [
        (["materials", "--materials", d / "zero"], "a character device, not a regular file"),
        (["materials", "--materials", tmp_path / "zero.toml"], "a character device"),
        (["materials", "--materials", tmp_path / "fifo.toml"], "a FIFO, not a regular file"),
        (["simulate", "--steps", "1", "--scene", tmp_path / "zero.toml"], "a character device"),
        (["simulate", "--steps", "1", "--scene", tmp_path / "fifo.toml"], "a FIFO"),
        ([*render, "--scene", tmp_path / "fifo.toml"], "a FIFO"),
        ([*render, "--load-state", tmp_path / "Szero"], "a character device"),
        ([*render, "--load-state", tmp_path / "Sfifo"], "a FIFO"),
    ]
    lines = [separated(dentdemo_line(*argv)) for argv, _ in runs]
    # The refusal itself, timed inside one process (a process's start is seconds on a loaded
    # machine): each read of the device, the link and the FIFO ends within a second.
    probe = (
        "import sys, time\nfrom dentdemo.model.validate import read_input\n"
        "for p in sys.argv[1:]:\n    t = time.perf_counter()\n    try:\n"
        "        read_input(p, 1 << 30)\n    except OSError as e:\n"
        "        print('took', time.perf_counter() - t, e.strerror)\n"
    )
    (tmp_path / "probe.py").write_text(probe)
    paths = [d / "zero", tmp_path / "zero.toml", tmp_path / "fifo.toml"]
    paths.append(tmp_path / "Sfifo" / "steel_plate.npy")
    lines.append(f"{sys.executable} {tmp_path / 'probe.py'} {' '.join(map(str, paths))}")
    done = in_namespace(setup, lines, tmp_path, timeout=240)
    got = results(done)
    assert len(got) == len(runs), done.stderr
    for (argv, fragment), (code, err) in zip(runs, got, strict=True):
        assert code == 1 and len(err) == 1 and fragment in err[0], (argv, code, err)
    took = [line.split() for line in done.stdout.splitlines() if line.startswith("took ")]
    assert len(took) == len(paths), done.stdout
    assert all(float(t[1]) < 1.0 and "not a regular file" in " ".join(t) for t in took), took


def test_a_fifo_is_never_opened_by_a_reader_or_the_watcher(tmp_path):
    """The demo's watcher read a watched FIFO and froze the window (Esc ignored); a 200 MB
    watched file was hashed five times a second (22 -> 3.4 fps). The watcher and load_toml
    return at once on a FIFO (run in a thread: a blocked open would keep it alive), and a
    file over the bound is fingerprinted by its size, not read."""

    from dentdemo.app.watch import FileWatcher
    from dentdemo.errors import ConfigError
    from dentdemo.model.validate import TOML_MAX, load_toml

    fifo = tmp_path / "m.toml"
    os.mkfifo(fifo)
    big = tmp_path / "big.toml"
    with open(big, "wb") as handle:
        handle.truncate(200 << 20)  # sparse: 200 MB of zeros
    seen: list[object] = []

    def work() -> None:
        watcher = FileWatcher((fifo, big))
        seen.append(watcher._known[fifo])
        seen.append(watcher._known[big])
        try:
            load_toml(fifo)
        except ConfigError as exc:
            seen.append(str(exc))

    thread = threading.Thread(target=work, daemon=True)
    thread.start()
    thread.join(timeout=10.0)
    if thread.is_alive():  # blocked in open(): give it a writer, so that it ends
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(timeout=10.0)
        raise AssertionError("a reader opened the FIFO and blocked")
    assert str(seen[0]).startswith("unreadable: a FIFO, not a regular file")
    assert str(seen[1]).startswith(f"unreadable: {200 << 20} bytes, more than the {TOML_MAX}")
    assert seen[2] == f"{fifo}: cannot read: a FIFO, not a regular file"


_KEYS = """
import json, sys
import glfw
from dentdemo.app.loop import FrameLoop
from dentdemo.app.window import DemoWindow
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
lib = load_materials()
window = DemoWindow(load_scene(sys.argv[1], lib), lib, (320, 180), "low")
loop = FrameLoop(window.app, window, fixed_dt=True)
loop.frame()
lines = []
for key in (glfw.KEY_P, glfw.KEY_G, glfw.KEY_F5):
    window._on_key(window.window, key, 0, glfw.PRESS, 0)
    lines.append(window.app.message)
    loop.frame()  # and it runs on
window.close()
print(json.dumps(lines))
"""


@needs_namespace
@pytest.mark.slow
def test_demo_keys_in_a_read_only_folder_are_panel_lines(xvfb, tmp_path):
    """Started in a read-only folder, P (screenshot) and G (glTF) killed the demo with
    `OSError: Read-only file system`, while F5 showed a panel line. All three are panel lines
    now, and the window runs on."""

    ro = tmp_path / "ro"
    ro.mkdir()
    (tmp_path / "keys.py").write_text(_KEYS)
    scene = Path(__file__).resolve().parents[1] / "assets" / "scenes" / "ball_drop.toml"
    setup = [f"mount -t tmpfs -o ro,size=1m none {ro}", f"cd {ro}"]
    line = f"DISPLAY={xvfb} {sys.executable} {tmp_path / 'keys.py'} {scene}; echo rc=$?"
    done = in_namespace(setup, [line], tmp_path, timeout=180)
    assert "rc=0" in done.stdout, done.stderr
    shot, gltf, save = json.loads(done.stdout.splitlines()[-2])
    assert "dentdemo_001.png" in shot and "Read-only file system" in shot, shot
    assert "dentdemo.glb" in gltf and "Read-only file system" in gltf, gltf
    assert "dentdemo_state" in save and "not writable" in save, save


_STORM = """
import json, random, sys
import glfw
from dentdemo.app.loop import FrameLoop
from dentdemo.app.window import DemoWindow
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
lib = load_materials()
window = DemoWindow(load_scene(sys.argv[1], lib), lib, (320, 180), "low")
loop = FrameLoop(window.app, window, fixed_dt=True)
imgui = window.imgui
backends = imgui.backends
read_sizes = backends.glfw_new_frame
raced = float(sys.argv[2])


class Racing:
    # imgui's backends, glfw's new frame having read the window's size before a resize landed
    # and the framebuffer's after it: the scale that race gives (8000 px / 40 px = 200).
    def __getattr__(self, name):
        return getattr(backends, name)

    def glfw_new_frame(self):
        read_sizes()
        imgui.get_io().display_framebuffer_scale = (raced, raced)


imgui.backends = Racing()
for _ in range(3):
    loop.frame()
imgui.backends = backends
scale = imgui.get_main_viewport().framebuffer_scale.x
atlas = [imgui.get_io().fonts.tex_data.width, imgui.get_io().fonts.tex_data.height]
# ... and real resizes: 1 x 1, 8000 x 8000, 1 x 8000, unmapped, a few random ones.
rng = random.Random(9)
sizes = [(1, 1), (8000, 8000), (1, 8000)] + [(rng.randint(1, 3000), rng.randint(1, 3000))] * 4
for w, h in sizes:
    glfw.set_window_size(window.window, w, h)
    loop.frame()
glfw.hide_window(window.window)
loop.frame()
glfw.show_window(window.window)
glfw.set_window_size(window.window, 320, 180)
loop.frame()
window.close()
print(json.dumps({"scale": scale, "atlas": atlas}))
"""


@pytest.mark.parametrize("raced", [200.0, 1000.0])
@pytest.mark.slow
def test_a_resize_storm_cannot_exhaust_the_font_atlas(xvfb, raced):
    """Issue 46 item 9: once in five resize storms the window died in imgui.new_frame() with
    "IM_ASSERT Out of texture memory" (imgui_freetype.cpp:532): a resize between glfw's two
    size reads gave a framebuffer scale of hundreds and imgui baked its font at that scale. The
    race is replayed (its scale set where glfw's backend sets it), then real resizes: the
    scale is clamped to 4 and the font atlas stays small."""

    scene = Path(__file__).resolve().parents[1] / "assets" / "scenes" / "ball_drop.toml"
    env = {**os.environ, "DISPLAY": xvfb}
    got = python_json(_STORM, scene, raced, env=env, timeout=300)
    assert got["scale"] == 4.0
    assert got["atlas"][0] * got["atlas"][1] <= 1024 * 1024, got  # 4096 x 8192 at 100


def test_an_output_that_is_a_link_is_written_through_it(tmp_path, monkeypatch, capsys):
    """A link to a regular file (as /dev/stdout is, redirected to one) is written through: the
    link stays a link, its target gets the PNG; renaming over the link replaced it with a
    file (and /dev/stdout with a PNG as root)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "r.png"
    target.write_bytes(b"old")
    (tmp_path / "link.png").symlink_to(target)
    assert main([*RENDER, "--out", "link.png"]) == 0
    assert (tmp_path / "link.png").is_symlink()
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.png", "real"]
    assert sorted(p.name for p in (tmp_path / "real").iterdir()) == ["r.png"]


def test_the_editors_save_to_a_fifo_is_one_line_and_never_blocks(tmp_path):
    """The material editor's "save to file" read the file it edits: a FIFO there froze the
    window. It is refused at once (run in a thread: a blocked open would keep it alive)."""
    from dentdemo.app.materials_save import save_preset
    from dentdemo.errors import ConfigError
    from dentdemo.model.materials import load_materials, material_table

    fifo = tmp_path / "mine.toml"
    os.mkfifo(fifo)
    lib = load_materials()
    table = material_table(lib.materials["lead"])
    seen: list[str] = []

    def save() -> None:
        try:
            save_preset(fifo, "lead", table, lib.calibration)
        except ConfigError as exc:
            seen.append(str(exc))

    thread = threading.Thread(target=save, daemon=True)
    thread.start()
    thread.join(timeout=10.0)
    if thread.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))  # end the blocked read
        thread.join(timeout=10.0)
        raise AssertionError("the save opened the FIFO and blocked")
    assert seen == [f"{fifo}: cannot read: a FIFO, not a regular file"]
    assert stat.S_ISFIFO(fifo.stat().st_mode)


def test_a_killed_writes_temporary_file_is_removed_by_the_next_write(tmp_path, monkeypatch, capsys):
    """A PNG written atomically and killed before its rename leaves `.r.png.<random>.tmp`;
    the next write of r.png removes it and says so once."""
    monkeypatch.chdir(tmp_path)
    dead = tmp_path / ".r.png.ab12cd34.tmp"
    dead.write_bytes(b"half a png")
    assert main([*RENDER, "--out", "r.png"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"dentdemo: removed 1 leftover of an interrupted write of 'r.png' ({dead.name})"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.png"]
