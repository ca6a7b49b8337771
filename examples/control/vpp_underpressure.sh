#!/bin/sh
# One switched Bouc-Wen model across the five underpressures of one material (the shipped synthetic
# VPP specimens carry underpressure_MPa in data/specimens/manifest.json): which parameters may vary,
# the laws --law auto chooses, and held-out underpressures. Run from anywhere; ~10-20 min on 2 busy cores.
# What it printed is in docs/control.md ("A worked example: underpressure").
set -e
D="$(cd "$(dirname "$0")/../.." && pwd)/data/specimens"
OUT="${1:-/tmp/vpp_underpressure}"
mkdir -p "$OUT"
# 1. each level fitted alone, the laws chosen from the per-level values and their errors, one model:
bwbench fit "$D"/pom-c9021_*.csv --formulation identifiable --control underpressure_MPa --law auto \
    --budget 2000 --out "$OUT/auto.json" --laws-figure "$OUT/auto_laws.png" --plot "$OUT/auto_fit.png"
# 2. the hysteresis shape held, every solved coefficient quadratic in the underpressure, and each level
#    left out in turn (against each file alone and against the nearest level's constants):
bwbench fit "$D"/pom-c9021_*.csv --formulation identifiable --control underpressure_MPa \
    --law c+=quadratic,k+=quadratic,h+=quadratic,c-=quadratic,k-=quadratic,h-=quadratic \
    --budget 2000 --out "$OUT/coefficients.json" --laws-figure "$OUT/coefficients_laws.png" --leave-one-level-out
