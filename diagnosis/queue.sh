#!/bin/bash
# $1 core, $2 root, $3 tag, then seeds
core=$1; root=$2; tag=$3; shift 3
cd $root; . /work/main/.venv/bin/activate; export OPENBLAS_NUM_THREADS=1
for s in "$@"; do
  case $s in
    r*) seed=${s#r}; taskset -c $core python benchmarks/markerless_errors.py --data data/sensor-bands/paper-real-1.2-with-train --pool-train --max-placements 5 --shared-intrinsics --pixel-effect-px 2 --cases 1,6,10 --seed $seed --out /tmp/wp/${tag}_s$seed.md > /tmp/wp/${tag}_s$seed.log 2>&1 ;;
    s*) seed=${s#s}; taskset -c $core python benchmarks/markerless_errors.py --data data/sensor-bands/paper-sim-1.2 --max-placements 24 --shared-intrinsics --pixel-effect-px 2 --cases 1,10 --seed $seed --out /tmp/wp/${tag}_sim_s$seed.md > /tmp/wp/${tag}_sim_s$seed.log 2>&1 ;;
  esac
done
