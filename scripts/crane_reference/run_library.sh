#!/bin/bash
# The library's refined solves, one after the other (each capped at 300 s); run from /work/main, venv active.
cd /work/main
for TOL in 1e-4 1e-5 1e-6 1e-7; do
  timeout -s KILL 300 python scripts/crane_reference/library_run.py $TOL > scripts/crane_reference/lib_$TOL.log 2>&1
  echo "rc=$?" >> scripts/crane_reference/lib_$TOL.log
done
