#!/bin/bash
# Every refined run of this check, one solve at a time, each tolerance its own capped subprocess (run.py all).
# Run against a fixed snapshot of the library:  LIB=/tmp/nc14_snapshot ./all.sh   (LIB unset: the live tree)
[ -n "$LIB" ] && export PYTHONPATH="$LIB"
T="1e-4 1e-5 1e-6 1e-7"
python run.py all block_tf $T --eps 1e-2
python run.py all block_tf $T --eps 1e-2 --coords maximal
python run.py all block_tf $T --eps 1e-4
python run.py all block_tf $T --eps 1e-6
python run.py all block_tf_speed $T --eps 1e-2
python run.py all block_tf_speed $T --eps 1e-2 --coords maximal
python run.py all block_tf_speed $T --eps 1e-4
python run.py all block_tf_speed $T --eps 1e-6
python run.py all block_tf_speed_t0 $T
python run.py all block_tf_speed_t0 1e-5 1e-6 --coords maximal
python run.py all block_tf_speed_t0 1e-6 1e-7 --mesh-at 0.5367905441380045,0.6645724629964861
python run.py all block_tf_speed_tend $T
python run.py all pendulum_tf $T
python run.py all pendulum_tf $T --coords maximal
python run.py all pendulum_tf $T --eps 1e-4
python run.py all pendulum_tf $T --eps 1e-6
python run.py all pendulum_tf_speed $T
python run.py all pendulum_tf_speed $T --coords maximal
python run.py all pendulum_tf_speed $T --eps 1e-4
python run.py all pendulum_tf_speed $T --eps 1e-6
python run.py all pendulum_tf_speed_path $T
for a in "pendulum_tf_speed 1e-4 --eps 1e-4" "block_tf 1e-6 --eps 1e-6" "pendulum_tf 1e-5 --eps 1e-6" "block_tf_speed 1e-5 --eps 1e-6"; do
    set -- $a
    (ulimit -t 200; timeout -s KILL 290 python diag.py $a > "diag_$1_$2_$4.txt" 2>&1)
done
