"""Issue 46: every file in and out under faults. Outputs that are devices, FIFOs or sockets, in
folders that cannot be written, on a full disk; leftovers of killed writers; inputs that never
end or block; saved states that hold nonsense. Device nodes, read-only folders and full disks
live in a private mount namespace (tests/faults_helpers.py), never on the machine's own /dev."""

from __future__ import annotations

import os
import socket
import stat
from pathlib import Path

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
