"""The study database: written by the runner (``database``), read into tables by the report and the
Python API (``reader``), with the run-time bookkeeping both need (``timing``). It sits below the
runner and the report, so neither imports the other."""
