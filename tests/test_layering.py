"""Imports point only upstream, and each third-party package stays in its corner."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("machines", "toolpath", "gcode", "simulator", "verification", "streamline_cam")
# package -> our packages it may import
ALLOWED = {
    "machines": set(),
    "toolpath": {"machines"},
    "gcode": {"machines", "toolpath"},
    "simulator": {"machines", "gcode"},
    "verification": {"machines", "toolpath", "gcode"},
    "streamline_cam": {"machines", "toolpath", "gcode", "simulator", "verification"},
}
# third-party module -> path prefixes (relative to the root) allowed to import it
CORNERS = {
    "serial": ("gcode/senders/serial", "simulator/"),
    "pymodbus": ("gcode/senders/modbus", "simulator/modbus"),
    "scipy": ("toolpath/",),
    "shapely": ("toolpath/",),
    "matplotlib": ("toolpath/plotting", "streamline_cam/plots", "verification/plotting"),
    "fastapi": ("streamline_cam/service",),
    "uvicorn": ("streamline_cam/service", "streamline_cam/commands/serve"),
    "tqdm": ("streamline_cam/",),
    "dask": ("streamline_cam/dask_engine",),
    "distributed": ("streamline_cam/dask_engine",),
}


def _imports(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module.split(".")[0]


def test_imports_point_upstream_and_stay_in_their_corners():
    problems = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            for name in _imports(path):
                if name in PACKAGES and name != package and name not in ALLOWED[package]:
                    problems.append(f"{rel} imports {name} (not upstream of {package})")
                if name in CORNERS and not rel.startswith(CORNERS[name]):
                    problems.append(f"{rel} imports {name}, allowed only in {CORNERS[name]}")
    assert not problems, "\n".join(problems)
