"""How long a study took, and on what: for the report's "what was compared" paragraph.

A study may be run in several sessions (interrupted and resumed, or extended with more seeds), so its
elapsed time is not "last run end − first run start": the gaps between sessions are idle. Each run
stores its wall time and when it finished; the run intervals are merged, and merged intervals
separated by more than ``IDLE_GAP_S`` are counted as separate sessions.
"""

from __future__ import annotations

import os
import platform
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

IDLE_GAP_S = 60.0  # longer than any pause between two runs of one session (a worker's start-up included)


@dataclass(frozen=True)
class ComputeTime:
    elapsed_s: float  # sum over sessions of (last run end − first run start)
    core_s: float  # sum of the runs' wall times: each run uses one core
    sessions: int


def compute_time(runs: pd.DataFrame) -> ComputeTime | None:
    """Elapsed and core time of the runs (columns ``wall_s`` and ``finished_utc``); None when no run
    recorded both (databases from before timings were stored)."""
    if "finished_utc" not in runs or "wall_s" not in runs:
        return None
    end = pd.to_datetime(runs["finished_utc"], utc=True, errors="coerce")
    wall = pd.to_numeric(runs["wall_s"], errors="coerce")
    ok = end.notna().to_numpy() & np.isfinite(wall.to_numpy(dtype=float))
    if not ok.any():
        return None
    stop = (end[ok] - pd.Timestamp(0, tz="UTC")).dt.total_seconds().to_numpy()
    wall = wall[ok].to_numpy(dtype=float)
    order = np.argsort(stop - wall)
    # Merge the run intervals [start, finish] into sessions separated by idle gaps > IDLE_GAP_S.
    sessions: list[list[float]] = []
    for start, finish in zip((stop - wall)[order], stop[order], strict=True):
        if not sessions or start > sessions[-1][1] + IDLE_GAP_S:
            sessions.append([float(start), float(finish)])
        else:
            sessions[-1][1] = max(sessions[-1][1], float(finish))
    elapsed = sum(finish - start for start, finish in sessions)
    return ComputeTime(elapsed_s=float(elapsed), core_s=float(wall.sum()), sessions=len(sessions))


def machine_description() -> str:
    """E.g. "Linux x86_64, 2 cores, AMD EPYC 7B13": where ``compare`` ran (Dask workers may be
    elsewhere; their host names are in each run's ``worker``)."""
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        cpu = platform.processor()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return ", ".join(x for x in (f"{platform.system()} {platform.machine()}", f"{cores} cores", cpu) if x)
