"""The kernel cache folder: numba's own in a writable package, a user folder otherwise."""

import tempfile
from pathlib import Path

from toolpath.kernel_cache import PACKAGE_DIR, choose_cache_dir


def test_a_writable_package_keeps_numba_s_folder_and_the_variable_wins(tmp_path):
    assert choose_cache_dir({}, tmp_path) is None
    assert choose_cache_dir({"NUMBA_CACHE_DIR": "/x/y"}, tmp_path,
                            writable=lambda _folder: False) == Path("/x/y")


def test_a_read_only_package_caches_in_the_user_folder(tmp_path):
    read_only = tmp_path / "site-packages" / "toolpath"
    environ = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    folder = choose_cache_dir(environ, read_only,
                              writable=lambda f: not f.is_relative_to(read_only)
                              and f.mkdir(parents=True, exist_ok=True) is None)
    assert folder == tmp_path / "cache" / "streamline-cam" / "kernels" and folder.is_dir()
    environ = {"HOME": str(tmp_path / "home")}  # no XDG_CACHE_HOME: ~/.cache
    assert choose_cache_dir(environ, read_only, writable=lambda f: f != read_only / "__pycache__"
                            ) == tmp_path / "home" / ".cache" / "streamline-cam" / "kernels"


def test_with_no_writable_home_the_temporary_folder(tmp_path):
    read_only = tmp_path / "ro"
    folder = choose_cache_dir({"HOME": str(read_only)}, read_only,
                              writable=lambda f: not f.is_relative_to(read_only))
    assert folder is not None and folder.parent == Path(tempfile.gettempdir())


def test_the_package_folder_is_the_toolpath_package():
    assert (PACKAGE_DIR / "compiled.py").is_file()
