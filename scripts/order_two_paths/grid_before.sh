#!/bin/bash
# The same runs on the code before session 32 (a worktree of be055a8 at /work/before32): runs_before.jsonl.
cd "$(dirname "$0")"
out=runs_before.jsonl
: > $out
for p in pend_sin pend_x bd_wall; do for tol in 1e-4 1e-5 1e-6 1e-7; do
  PYTHONPATH=/work/before32 timeout -s KILL 300 python run.py $p $tol 2>/dev/null | tail -1 >> $out || echo "{\"problem\": \"$p\", \"coordinates\": \"auto\", \"tol\": $tol, \"error\": \"killed at 300 s or failed\"}" >> $out
done; done
