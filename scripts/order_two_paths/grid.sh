#!/bin/bash
# Every problem, both coordinate forms, tolerances 1e-4..1e-8: one JSON line each in runs_$1.jsonl.
cd "$(dirname "$0")"
out=runs_${1:-now}.jsonl
: > $out
for c in auto maximal; do for p in pend_sin pend_x bd_wall; do for tol in 1e-4 1e-5 1e-6 1e-7 1e-8; do
  timeout -s KILL 300 python run.py $p $tol --coordinates $c 2>/dev/null | tail -1 >> $out || echo "{\"problem\": \"$p\", \"coordinates\": \"$c\", \"tol\": $tol, \"error\": \"killed or failed\"}" >> $out
done; done; done
