"""Write files so that no half-written file is ever left behind.

Everything the project writes goes through :func:`atomic_path`: the caller writes to a
temporary name in the same directory, and the file is renamed into place only when the
writer returned without error.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from sandbox.errors import SandboxError


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` on success.

    The temporary name keeps the suffix, so writers that choose a format by extension
    (Open3D, imageio) still work. On error the temporary file is removed.
    """
    final = Path(path)
    make_dir(final.parent)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=final.suffix,
                                   dir=final.parent)  # fmt: skip
    except OSError as exc:
        raise SandboxError(f"{final}: cannot write in {final.parent} ({exc.strerror})") from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if not tmp_path.exists() or tmp_path.stat().st_size == 0:
            raise OSError(f"{final}: the writer produced no data")
        os.chmod(tmp_path, 0o644)  # mkstemp makes 0600; outputs are ordinary files
        try:
            os.replace(tmp_path, final)
        except OSError as exc:
            raise SandboxError(f"{final}: cannot write it ({exc.strerror})") from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def make_dir(path: str | os.PathLike) -> Path:
    """Create the folder ``path`` and its parents (if missing); a SandboxError naming the
    path if a file stands in the way or it cannot be created."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise SandboxError(f"{p}: exists and is not a directory") from None
    except OSError as exc:
        raise SandboxError(f"{p}: cannot create the directory ({exc.strerror})") from None
    return p


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; return the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_json(path: str | os.PathLike, data) -> Path:
    """Write ``data`` as indented JSON atomically; return the path."""
    return write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")
