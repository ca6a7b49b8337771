"""bwbench's figures are drawn on their own Agg canvas: importing and using the figure code chooses no
backend for the process and starts no pyplot (a notebook's backend stays as it was)."""

import subprocess
import sys


def test_drawing_and_writing_a_figure_chooses_no_backend_and_imports_no_pyplot(tmp_path):
    script = f"""
import sys
import matplotlib
matplotlib.rcParams["backend"] = "pdf"
from bwbench.render import palette, run_figures, ecdf_figures, waterfall, fit_plots
from bwbench.problems.hysteresis.report import fit_figures, parameter_figures, posterior_figures, profile_figures
palette.theme()
fig, ax = palette.figure(4, 3)
ax.plot([0, 1], [0, 1])
palette.write_png(fig, {str(tmp_path / "f.png")!r}, False)
print(dict.__getitem__(matplotlib.rcParams, "backend"), "matplotlib.pyplot" in sys.modules)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["pdf", "False"]
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
