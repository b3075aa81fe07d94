"""Where the compiled kernels are kept: one cache per install that every process reuses.

The planner's kernels are numba functions with ``cache=True``: compiled on first use, then
written to disk and loaded by every later process (a service's workers, batch jobs), so
nothing compiles per job. numba keeps them in ``__pycache__`` next to each source file when
that folder is writable (a source checkout, ``pip install -e``), else in a user folder. A
system-wide install (read-only site-packages) run by a user whose home is read-only too (a
service account, a container) would leave numba no folder at all: it then refuses to import
the planner. :func:`ensure_kernel_cache` (run by ``import toolpath``, before any kernel
module loads numba) settles the folder first:

1. ``NUMBA_CACHE_DIR`` when set (e.g. a temporary folder for a cold-start benchmark);
2. numba's own choice when the package folder is writable;
3. else ``$XDG_CACHE_HOME/streamline-cam/kernels`` (``~/.cache/...``), else a folder in the
   system's temporary directory, whichever is writable first (set as ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Callable, MutableMapping
from pathlib import Path

__all__ = ["choose_cache_dir", "ensure_kernel_cache"]

PACKAGE_DIR = Path(__file__).resolve().parent


def _writable(folder: Path) -> bool:
    """Whether files can be created in ``folder`` (created if missing)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def choose_cache_dir(environ: MutableMapping[str, str], package_dir: Path = PACKAGE_DIR,
                     writable: Callable[[Path], bool] = _writable) -> Path | None:
    """The kernel cache folder to set, or None where numba's default works (see above).

    ``NUMBA_CACHE_DIR`` from ``environ`` wins; a writable ``package_dir`` keeps numba's
    in-tree ``__pycache__``; else the first writable of the user cache folder and the
    temporary one.
    """
    given = environ.get("NUMBA_CACHE_DIR")
    if given:
        return Path(given)
    if writable(package_dir / "__pycache__"):
        return None
    home = environ.get("XDG_CACHE_HOME") or str(Path(environ.get("HOME") or "~").expanduser()
                                                / ".cache")
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    for folder in (Path(home) / "streamline-cam" / "kernels",
                   Path(tempfile.gettempdir()) / f"streamline-cam-kernels-{uid}"):
        if writable(folder):
            return folder
    return None


def ensure_kernel_cache() -> Path | None:
    """Settle the kernel cache folder for this process (see the module's text).

    Sets ``NUMBA_CACHE_DIR`` (and numba's setting, if numba is loaded already) when the
    package folder is read-only; returns the folder set, or None for numba's default.
    """
    folder = choose_cache_dir(os.environ)
    if folder is None or os.environ.get("NUMBA_CACHE_DIR"):
        return folder
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = getattr(sys.modules.get("numba"), "config", None)
    if config is not None:
        config.CACHE_DIR = str(folder)
    return folder
