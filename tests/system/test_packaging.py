"""What a wheel holds: every package folder is listed in pyproject.toml (setuptools installs only the
packages it names, so a folder left out works from the checkout and is missing from a wheel), and a
wheel installed on its own finds its shipped data (``importlib.resources``) and runs from another
folder."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = {
    "bwbench": ROOT / "src" / "bwbench",
    "bwbench.optimizers": ROOT / "optimizers",
    "bwbench.shipped": ROOT / "data",
}


def test_every_package_folder_is_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["packages"])
    folders = set()
    for package, root in FOLDERS.items():
        for path in [root, *(p for p in root.rglob("*") if p.is_dir())]:
            if path.name == "__pycache__" or "__pycache__" in path.parts:
                continue
            if (path / "__init__.py").is_file() or (package == "bwbench.shipped" and any(path.glob("*.csv"))):
                folders.add(".".join((package, *path.relative_to(root).parts)))
    assert folders == listed, f"not listed: {sorted(folders - listed)}; listed, no folder: {sorted(listed - folders)}"


def test_a_wheel_on_its_own_finds_its_data_and_runs_from_another_folder(tmp_path):
    built = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stderr
    wheel = next(tmp_path.glob("bwbench-*.whl"))
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    assert (site / "bwbench" / "shipped" / "specimens" / "manifest.json").is_file()
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {**os.environ, "PYTHONPATH": str(site), "BWBENCH_PROGRESS": "0"}

    def run(*args):
        return subprocess.run([sys.executable, *args], cwd=work, env=env, capture_output=True, text=True)

    where = run("-c", "import bwbench, bwbench.datasets.shipped as s; print(bwbench.__file__, s.SHIPPED, s.CHECKOUT)")
    assert where.stdout.split() == [str(site / "bwbench" / "__init__.py"), str(site / "bwbench" / "shipped"), "None"]
    generated = run("-m", "bwbench", "data", "generate", "--mr-damper")
    assert generated.returncode == 0, generated.stderr
    assert sorted(p.name for p in (work / "mr_damper").iterdir()) == sorted(
        p.name for p in (site / "bwbench" / "shipped" / "mr_damper").iterdir() if p.suffix in (".csv", ".json")
    )
    # a fit from the wheel compiles every kernel afresh (~45 s of CPU, no numba cache there): data check
    # reads a generated file the way fit reads it (the whole check by hand: docs/contributing.md)
    checked = run("-m", "bwbench", "data", "check", "mr_damper/mr_10mm_2Hz_1V.csv")
    assert checked.returncode == 0 and checked.stdout.startswith("ok: mr_damper/mr_10mm_2Hz_1V.csv"), checked
