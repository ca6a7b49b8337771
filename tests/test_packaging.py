"""Every sub-package is listed in pyproject.toml: setuptools installs only the packages it names, so a
folder left out works from the checkout (editable) and is missing from a built wheel."""

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_folder_is_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["packages"])
    folders = {
        ".".join(("bwbench", *p.parent.relative_to(ROOT / "src" / "bwbench").parts))
        for p in (ROOT / "src" / "bwbench").rglob("__init__.py")
    } | {"bwbench.optimizers"}
    assert folders == listed, f"not listed: {sorted(folders - listed)}; listed, no folder: {sorted(listed - folders)}"
