"""The maps stay complete and current: every planning module in the package index, every
module (and command) a row of the architecture page, and no row for a module that is gone."""

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOP = ("machines", "toolpath", "gcode", "simulator", "verification", "streamline_cam")
PAGE = ROOT / "docs/architecture.md"


def _packages() -> list[str]:
    """Every package (a folder with ``__init__.py``) of the project, as a relative path."""
    return sorted(str(init.parent.relative_to(ROOT)) for top in TOP
                  for init in (ROOT / top).rglob("__init__.py"))


def _modules(package: str) -> list[str]:
    return sorted(p.stem for p in (ROOT / package).glob("*.py") if p.stem != "__init__")


def _page_rows() -> dict[str, str]:
    """Module path -> its table row, from the page's ``## `package/``` sections.

    A name in a row is relative to its section's package; ``service/app.py`` names a
    sub-package, and the bare names after it in the same cell are in it too.
    """
    rows, section = {}, None
    for line in PAGE.read_text().splitlines():
        if line.startswith("## "):
            heading = re.match(r"## `([\w/]+)/`", line)
            section = heading.group(1) if heading else None
        elif section and line.startswith("| `"):
            folder = section
            for name in re.findall(r"`([\w/]+\.py)`", line.split("|")[1]):
                if "/" in name:
                    sub, name = name.rsplit("/", 1)
                    folder = f"{section}/{sub}"
                rows[f"{folder}/{name}"] = line
    return rows


def test_planning_index_lists_every_module():
    doc = ast.get_docstring(ast.parse((ROOT / "toolpath/planning/__init__.py").read_text()))
    index = doc.split("Modules\n-------\n", 1)[1]
    listed = {name.strip() for line in index.splitlines() if line and not line[0].isspace()
              for name in line.split(",")}
    assert listed == set(_modules("toolpath/planning"))


def test_architecture_page_has_a_row_for_every_module():
    rows = _page_rows()
    packages = [p for p in _packages() if p != "streamline_cam/commands"]
    missing = [f"{p}/{m}.py" for p in packages for m in _modules(p) if f"{p}/{m}.py" not in rows]
    assert not missing, f"docs/architecture.md has no row for {missing}"


def test_architecture_page_names_no_module_that_is_gone():
    gone = [path for path in _page_rows() if not (ROOT / path).is_file()]
    assert not gone, f"docs/architecture.md has rows for modules that do not exist: {gone}"


def test_architecture_page_lists_the_commands_there_are():
    row = next(line for line in PAGE.read_text().splitlines()
               if line.startswith("| `commands/` |"))
    listed = set(re.findall(r"`([\w-]+)`", row.split("|")[2]))
    files = {m.replace("_", "-") for m in _modules("streamline_cam/commands")}
    assert listed == files
