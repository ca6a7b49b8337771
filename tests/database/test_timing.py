"""How long a study took: run intervals merged into sessions, idle gaps between sessions left out."""

import pandas as pd

from bwbench.database.timing import compute_time, machine_description


def _runs(rows):
    return pd.DataFrame(rows, columns=["wall_s", "finished_utc"])


def test_two_workers_in_two_sessions_count_only_the_busy_time():
    runs = _runs(
        [
            # session 1, two workers side by side: 10:00:00 to 10:00:30
            (10.0, "2026-11-22T10:00:10Z"),
            (20.0, "2026-11-22T10:00:30Z"),
            (15.0, "2026-11-22T10:00:25Z"),
            (5.0, "2026-11-22T10:00:30Z"),
            # resumed an hour later: 11:00:00 to 11:00:12
            (12.0, "2026-11-22T11:00:12Z"),
            (4.0, "2026-11-22T11:00:04Z"),
        ]
    )
    took = compute_time(runs)
    assert took.sessions == 2
    assert took.elapsed_s == 30.0 + 12.0
    assert took.core_s == 66.0


def test_runs_without_times_give_nothing_rather_than_a_wrong_time():
    assert compute_time(_runs([(None, None), (3.0, None)])) is None
    assert compute_time(pd.DataFrame({"mse": [1.0]})) is None
    one = compute_time(_runs([(3.0, "2026-11-22T10:00:03Z"), (None, "2026-11-22T10:00:09Z")]))
    assert (one.sessions, one.elapsed_s, one.core_s) == (1, 3.0, 3.0)


def test_machine_names_its_cores():
    assert " cores" in machine_description()
