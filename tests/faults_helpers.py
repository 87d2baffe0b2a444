"""Running commands in a private mount namespace (`unshare -m`, as root): the tmpfs folders,
device nodes and full disks a test makes there are its own, never the machine's, and vanish
with the namespace."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest


def namespaces_work() -> bool:
    """True where this process may make a private mount namespace and mount a tmpfs in it."""
    if os.geteuid() != 0:
        return False
    try:
        done = subprocess.run(
            ["unshare", "-m", "sh", "-c", "mount -t tmpfs none /mnt && umount /mnt"],
            capture_output=True,
            timeout=30,
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


#: Tests that need a namespace: they need root and util-linux's unshare.
needs_namespace = pytest.mark.skipif(
    not namespaces_work(), reason="needs root and unshare -m (a private mount namespace)"
)


def dentdemo_line(*args: object) -> str:
    """A shell line running `python -m dentdemo ARGS` that prints `rc=N` after it."""
    words = [sys.executable, "-m", "dentdemo", *(str(a) for a in args)]
    return f"{shlex.join(words)}; echo rc=$?"


def in_namespace(
    setup: list[str], lines: list[str], cwd: Path, timeout: float = 300
) -> subprocess.CompletedProcess:
    """Run the shell `setup` lines (mounts, mknod; each must succeed) and then `lines` in a new
    private mount namespace, in `cwd`, without a display."""
    script = " && ".join(setup) + "\n" + "\n".join(lines) + "\n"
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env.setdefault("DENTDEMO_GL_BACKEND", "egl")
    command = ["unshare", "-m", "--propagation", "private", "sh", "-c", script]
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
        env=env,
        start_new_session=True,  # a timeout ends every command the script started
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise
    return subprocess.CompletedProcess(command, proc.returncode, out, err)


def results(done: subprocess.CompletedProcess) -> list[tuple[int, list[str]]]:
    """Each command's (exit status, its stderr lines), from the `rc=N` markers on stdout and the
    stderr lines between them (stderr is read whole: commands must write `---` on stderr
    after each, which `dentdemo_line` callers add with `separated`)."""
    codes = [int(line[3:]) for line in done.stdout.splitlines() if line.startswith("rc=")]
    chunks = done.stderr.split("---\n")
    return [(code, chunks[i].strip().splitlines()) for i, code in enumerate(codes)]


def separated(line: str) -> str:
    """`line`, then a `---` separator on stderr (see `results`)."""
    return f"{line}; echo --- >&2"
