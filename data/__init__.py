"""The data bwbench ships, installed with it as the package ``bwbench.shipped``: the paper's tables
(``paper/``), the synthetic specimens generated from them (``specimens/``) and the synthetic MR-damper
tests (``mr_damper/``). Code finds them with ``importlib.resources`` (``bwbench.datasets.shipped``),
never through the path of a source checkout."""
