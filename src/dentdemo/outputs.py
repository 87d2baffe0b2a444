"""Every file dentdemo writes goes through here: output paths are checked before any work starts,
and each file is written atomically (a temporary file in the same folder, then a rename), so an
error or Ctrl-C never leaves a half-written file or replaces a good one with a broken one."""

from __future__ import annotations

import ctypes
import errno
import fcntl
import io
import json
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

from dentdemo import log
from dentdemo.errors import DentdemoError

if TYPE_CHECKING:  # numpy loads when an array is written: the commands' start stays light
    import numpy as np
    from numpy.typing import NDArray

#: The longest file name most file systems take, bytes.
NAME_MAX = 255


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


#: The suffixes of each format a writer may be asked for (checked against an output's name).
PNG, JSON = (".png",), (".json",)


#: What each kind of node is called in a refusal (an existing output must be a regular file).
_NODE_KINDS = (
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


def _node_kind(path: Path) -> str | None:
    """What `path` is when it exists and is neither a regular file nor a folder (a symbolic
    link is followed: one to /dev/null is a character device), else None."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return next((name for test, name in _NODE_KINDS if test(mode)), "not a regular file")


def _probe(flag: str, folder: Path, what: str) -> None:
    """Make and remove a temporary file in the existing `folder` (a temporary folder where
    `what` is "folder"), as a writer would: permissions, a read-only file system or sysfs
    refuse here, before any work, rather than after it (root passes os.access everywhere)."""
    try:
        if what == "folder":
            os.rmdir(tempfile.mkdtemp(prefix=".dentdemo-probe.", dir=folder))
        else:
            fd, name = tempfile.mkstemp(prefix=".dentdemo-probe.", dir=folder)
            os.close(fd)
            os.unlink(name)
    except OSError as exc:
        raise DentdemoError(f"{flag}: cannot write in folder '{folder}' ({_why(exc)})") from None


def _named(flag: str, path: Path | str, what: str) -> Path:
    """`path` as a Path; an empty or blank name (Path('') is '.') is an error."""
    if isinstance(path, str) and not path.strip():
        raise DentdemoError(f"{flag}: '{path}' is not a {what} name")
    return Path(path)


def check_output_dir(flag: str, path: Path | str) -> Path:
    """A folder that exists and is writable, or that can be made (its nearest existing ancestor is
    a writable folder), each tried by making a temporary file or folder there. Checked before
    any work; nothing is left behind until a file is written."""
    path = _named(flag, path, "folder")
    if path.exists():
        if not path.is_dir():
            kind = _node_kind(path) or "a file"
            raise DentdemoError(f"{flag}: '{path}' exists and is not a folder (it is {kind})")
        if not os.access(path, os.W_OK | os.X_OK):
            raise DentdemoError(f"{flag}: folder '{path}' is not writable")
        _probe(flag, path, "file")
        return path
    ancestor = path.absolute().parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise DentdemoError(f"{flag}: cannot create '{path}': '{ancestor}' is not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise DentdemoError(f"{flag}: cannot create '{path}': folder '{ancestor}' is not writable")
    _probe(flag, ancestor, "folder")
    return path


def check_output_file(flag: str, path: Path | str, suffixes: tuple[str, ...] = ()) -> Path:
    """A file path whose folder exists (or can be made) and is writable, that is not a folder, a
    device, a FIFO or a socket (a writer renames over its target: /dev/null would become a
    file), and that ends in one of `suffixes` (lower case, with the dot) where given, so that
    the bytes match the name; checked before any work."""
    path = _named(flag, path, "file")
    if path.name in ("", ".", ".."):
        raise DentdemoError(f"{flag}: '{path}' is not a file name")
    size = len(path.name.encode())
    if size > NAME_MAX:
        raise DentdemoError(
            f"{flag}: the file name '{path.name[:24]}...{path.name[-8:]}' is {size} bytes long; "
            f"a file name may have at most {NAME_MAX}"
        )
    if path.is_dir():
        raise DentdemoError(f"{flag}: '{path}' is a folder, not a file")
    check_regular(flag, path)
    path = _through_link(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise DentdemoError(f"{flag}: '{path}' must end in {' or '.join(suffixes)}")
    check_output_dir(flag, path.parent)
    if path.exists() and not os.access(path, os.W_OK):
        raise DentdemoError(f"{flag}: '{path}' is not writable")
    return path


def check_regular(flag: str, path: Path) -> None:
    """Refuse an existing `path` that is a device, FIFO or socket (or a link to one)."""
    kind = _node_kind(path)
    if kind is not None:
        raise DentdemoError(
            f"{flag}: '{path}' exists and is {kind}, not a regular file; nothing written"
        )


def _hidden_prefix(path: Path, suffix: str) -> str:
    """'.NAME.' with as much of `path`'s name as fits in NAME_MAX bytes beside tempfile's 8
    random characters and `suffix`."""
    room = NAME_MAX - len(f"..{'x' * 8}{suffix}".encode())
    stem = path.name.encode()[: max(room, 0)].decode(errors="ignore")
    return f".{stem}."


#: The suffix of write_atomic's temporary files.
TEMPORARY = ".tmp"


def temporary_beside(path: Path, suffix: str = TEMPORARY) -> tuple[int, Path]:
    """A new, empty, uniquely named hidden file in `path`'s folder (an open descriptor and its
    path), to write `path` atomically: its name starts with as much of `path`'s name as fits in
    NAME_MAX bytes beside the random part and `suffix`, so a legal final name never makes an
    illegal temporary one, and two writers of one name never share a temporary file."""
    fd, name = tempfile.mkstemp(prefix=_hidden_prefix(path, suffix), suffix=suffix, dir=path.parent)
    return fd, Path(name)


#: Suffixes of the folders `write_folder` makes beside its target: the new folder while it is
#: written, and the previous one while it is set aside (only where no atomic exchange exists).
NEW_FOLDER, OLD_FOLDER = ".new", ".old"


def leftovers_beside(path: Path, suffix: str) -> list[Path]:
    """Folders `write_folder` left beside `path` with `suffix` (a save killed mid-swap)."""
    pattern = f"{_hidden_prefix(path, suffix)}*{suffix}"
    return sorted(p for p in path.absolute().parent.glob(pattern) if p.is_dir())


#: Each folder's hidden names as first listed by this process (write_atomic's leftovers are
#: looked for once a folder: a render writing 10,000 frames lists its folder once, not 10,000
#: times).
_HIDDEN: dict[Path, list[str]] = {}


def _temporaries_beside(path: Path, suffix: str, fresh: bool = True) -> list[Path]:
    """The names `temporary_beside(path, suffix)` (or write_folder's mkdtemp) gives: the hidden
    prefix, tempfile's 8 random characters, `suffix`; nothing else matches. `fresh`: list the
    folder now, else as this process first listed it."""
    folder = path.absolute().parent
    name = re.compile(re.escape(_hidden_prefix(path, suffix)) + "[a-z0-9_]{8}" + re.escape(suffix))
    if fresh or folder not in _HIDDEN:
        try:
            _HIDDEN[folder] = [n for n in os.listdir(folder) if n.startswith(".")]
        except OSError:
            _HIDDEN[folder] = []
    return sorted(folder / n for n in _HIDDEN[folder] if name.fullmatch(n))


def hold(path: Path) -> int:
    """An open descriptor holding an exclusive lock on the temporary `path` (a file or a folder)
    while its writer lives: `remove_leftovers` of another writer leaves it alone. The lock goes
    with the process, however it ends."""
    return _locked(os.open(path, os.O_RDONLY))


def _locked(fd: int) -> int:
    """`fd`, locked where the file system has locks (where it has none, no writer there can
    tell a living writer's file from a killed one's, and `_unheld` removes nothing)."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        pass
    return fd


def _unheld(path: Path) -> bool:
    """True when no living writer holds `path` (its writer was killed or failed)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)
    return True


def remove_leftovers(flag: str, path: Path, suffix: str, fresh: bool = True) -> list[Path]:
    """Remove what killed writers of `path` left beside it (temporary files or folders ending in
    `suffix`, held by no living writer) and say so in one line; a writer calls it before it
    writes `path`, a reader never does. `fresh`: see `_temporaries_beside`."""
    removed = []
    for left in _temporaries_beside(path, suffix, fresh):
        if not _unheld(left):
            continue
        try:
            if left.is_dir() and not left.is_symlink():
                shutil.rmtree(left)
            else:
                left.unlink()
        except OSError:
            continue
        removed.append(left)
    if removed:
        names = ", ".join(p.name for p in removed[:3]) + (", ..." if len(removed) > 3 else "")
        what = "leftover" if len(removed) == 1 else "leftovers"
        who = "" if flag == str(path) else f"{flag}: "
        log.warn(
            f"dentdemo: {who}removed {len(removed)} {what} of an interrupted write of "
            f"'{path}' ({names})"
        )
    return removed


def check_replaceable_dir(flag: str, path: Path, holds: Callable[[str], bool], what: str) -> Path:
    """`check_output_dir`, and a folder that `write_folder` may replace as a whole: absent,
    empty, or holding only names for which `holds` is true (`what` names such a folder)."""
    if path.name in ("", ".", ".."):
        raise DentdemoError(f"{flag}: '{path}' must name a folder of its own (not . or ..)")
    check_output_dir(flag, path)
    if path.is_dir():
        try:
            foreign = sorted(name for name in os.listdir(path) if not holds(name))
        except OSError as exc:
            raise DentdemoError(f"{flag}: cannot list '{path}' ({_why(exc)})") from None
        if foreign:
            raise DentdemoError(
                f"{flag}: '{path}' holds '{foreign[0]}', which is not part of {what}; "
                "it is replaced as a whole, so only such a folder (or an empty one) is taken"
            )
    return path


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux renameat2 with RENAME_EXCHANGE); False where the
    system or the file system has no such call."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p]
    renameat2.argtypes += [ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def swap_in(new: Path, path: Path) -> None:
    """Give the complete folder `new` the name `path`. Where `path` exists, the two are exchanged
    in one step and the previous folder removed; where the system cannot exchange, the previous
    folder is renamed aside (`.NAME.*.old`), `new` renamed in, and the previous one removed; a
    kill between those two renames leaves no `path` but both folders beside it, and a load says
    so (`leftovers_beside`)."""
    if not path.exists():
        new.rename(path)
        return
    if _exchange(new, path):
        shutil.rmtree(new)  # the previous folder, now under the temporary name
        return
    old = Path(
        tempfile.mkdtemp(
            prefix=_hidden_prefix(path, OLD_FOLDER), suffix=OLD_FOLDER, dir=path.absolute().parent
        )
    )
    os.rmdir(old)  # a unique name for the previous folder
    path.rename(old)
    try:
        new.rename(path)
    except BaseException:
        old.rename(path)  # the previous folder back under its name
        raise
    shutil.rmtree(old)


def write_folder(path: Path, files: dict[str, bytes], flag: str = "save") -> Path:
    """Write `files` (name -> bytes) into a new folder beside `path` and swap it in as a whole
    (`swap_in`): a kill at any moment leaves the previous folder or the new one, never a mix.
    New folders that killed saves left beside `path` are removed first (`flag` names the
    writer in the line that says so)."""
    parent = path.absolute().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DentdemoError(f"{parent}: cannot create folder ({_why(exc)})") from None
    remove_leftovers(flag, path, NEW_FOLDER)
    new = Path(
        tempfile.mkdtemp(prefix=_hidden_prefix(path, NEW_FOLDER), suffix=NEW_FOLDER, dir=parent)
    )
    lock = hold(new)
    try:
        for name, data in files.items():
            (new / name).write_bytes(data)
            os.chmod(new / name, 0o644)
        os.chmod(new, 0o755)
        swap_in(new, path)
    except OSError as exc:
        shutil.rmtree(new, ignore_errors=True)
        raise DentdemoError(f"{path}: cannot write ({_why(exc)})") from None
    except BaseException:  # Ctrl-C or a bug: the previous folder stays, no new one is left
        shutil.rmtree(new, ignore_errors=True)
        raise
    finally:
        os.close(lock)
    return path


def _through_link(path: Path) -> Path:
    """Where writing `path` lands: a symbolic link's target (the link stays a link; renaming
    over the link itself would replace it, /dev/stdout with a file), else `path`."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def write_atomic(path: Path, write: Callable[[BinaryIO], None]) -> Path:
    """Call `write` on a temporary file beside `path` (a link's target), then rename it over
    it."""
    path = _through_link(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DentdemoError(f"{path.parent}: cannot create folder ({_why(exc)})") from None
    check_regular(str(path), path)
    remove_leftovers(str(path), path, TEMPORARY, fresh=False)
    try:
        fd, tmp = temporary_beside(path)
        lock = _locked(os.dup(fd))  # held until the rename, after the file is closed
    except OSError as exc:
        raise DentdemoError(f"{path}: cannot write ({_why(exc)})") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
        os.chmod(tmp, 0o644)
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise DentdemoError(f"{path}: cannot write ({_why(exc)})") from None
    except BaseException:  # Ctrl-C or a bug: no temporary file left behind
        tmp.unlink(missing_ok=True)
        raise
    finally:
        os.close(lock)
    return path


def write_bytes(path: Path, data: bytes) -> Path:
    def write(handle: BinaryIO) -> None:
        handle.write(data)

    return write_atomic(path, write)


def write_text(path: Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, payload: Any) -> Path:
    return write_text(path, json.dumps(payload, indent=2) + "\n")


def npy_bytes(array: NDArray[Any]) -> bytes:
    """An array as the bytes of a .npy file."""
    import numpy as np

    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def write_npy(path: Path, array: NDArray[Any]) -> Path:
    return write_bytes(path, npy_bytes(array))


def png_bytes(pixels: NDArray[Any]) -> bytes:
    """An image array (rows top-down; uint8 RGB/RGBA/grey or uint16 grey) as PNG bytes."""
    import numpy as np
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(pixels)).save(buffer, format="PNG")
    return buffer.getvalue()


def write_png(path: Path, pixels: NDArray[Any]) -> Path:
    """An image array (rows top-down; uint8 RGB/RGBA/grey or uint16 grey) as a PNG."""
    return write_bytes(path, png_bytes(pixels))


def write_normal_png(path: Path, normal: NDArray[np.uint8]) -> Path:
    """An RGBA8 normal map (row 0 is v = 0) as an RGB PNG, top row = v = 1 (image order)."""
    return write_png(path, normal[::-1, :, :3])


def write_height_png(path: Path, height: NDArray[np.float32], max_depth: float) -> Path:
    """Heights as 16-bit greyscale: 65535 = pristine (0 m), 0 = -max_depth; top row is v = 1."""
    import numpy as np

    scaled = np.clip(1.0 + height / max_depth, 0.0, 1.0) * 65535.0
    return write_png(path, np.round(scaled[::-1]).astype(np.uint16))
