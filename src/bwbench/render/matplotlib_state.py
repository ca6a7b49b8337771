"""Keep a notebook's matplotlib as it was across a call into bwbench's report code.

The report's figure modules are written for files: importing them selects the Agg backend and their
theme sets rcParams globally (``bwbench.render.palette``). In a notebook that would make every later
inline figure disappear. The API calls that reach that code (``Study.report``, ``Study.posterior``,
``Study.to_inference_data``, ``bwbench.compare``) run inside ``untouched()``: the backend pyplot
uses and every rcParam are put back afterwards.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager


@contextmanager
def untouched():
    """Within the block matplotlib may be changed; after it, its backend and rcParams are the old ones."""
    import matplotlib

    backend = dict.__getitem__(matplotlib.rcParams, "backend")  # raw: reading it must not resolve it
    if "matplotlib.pyplot" not in sys.modules and isinstance(backend, str):
        # A backend chosen but not yet started (a Jupyter kernel's inline one): start it now, as it would
        # start (IPython turns interactive mode on then), and keep the state it starts in.
        if not _inline_again(backend):
            import matplotlib.pyplot  # noqa: F401
    saved = matplotlib.rcParams.copy()
    try:
        yield
    finally:
        pyplot = sys.modules.get("matplotlib.pyplot")
        if pyplot is not None and dict.__getitem__(matplotlib.rcParams, "backend") != backend:
            pyplot.switch_backend(backend)  # the auto sentinel included: resolved again when first used
            _inline_again(backend)
        dict.update(matplotlib.rcParams, saved)  # as matplotlib.rc_context restores them


def _inline_again(backend) -> bool:
    """Jupyter's inline backend draws the figures of a cell from IPython hooks (and interactive mode) that a
    switch to Agg takes away: set them up as ``%matplotlib inline`` does. False outside IPython's inline."""
    if not (isinstance(backend, str) and "inline" in backend and "IPython" in sys.modules):
        return False
    from IPython import get_ipython

    shell = get_ipython()
    if shell is None:
        return False
    shell.enable_matplotlib("inline")
    return True
