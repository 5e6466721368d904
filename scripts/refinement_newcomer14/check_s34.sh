# From the repository root: bash scripts/refinement_newcomer14/check_s34.sh > scripts/refinement_newcomer14/check_s34.txt
# One refined solve per row (run.py one), CPU capped at 200 s; prints met, final points, CPU s, true errors, estimate.
. .venv/bin/activate
cd scripts/refinement_newcomer14
for spec in "block_tf 1e-6" "block_tf_speed 1e-6" "pendulum_tf 1e-6" "pendulum_tf_speed 1e-4" "block_tf 1e-4" "block_tf_speed 1e-4" "pendulum_tf 1e-4" "pendulum_tf_speed 1e-6"; do
 set -- $spec
 for t in 1e-4 1e-5 1e-6 1e-7; do
  r=$( (ulimit -t 200; timeout -s KILL 290 python run.py one $1 $t --eps $2) 2>&1 | grep '^ROW' | python -c "
import sys,json
l=sys.stdin.read().strip()
if not l: print('crash'); sys.exit()
d=json.loads(l[3:])
print(d.get('met'), d.get('points'), round(d.get('cpu_s',0),1), 'st %.1e mu %.1e est %s' % (d.get('true_states',-1), d.get('true_mult',-1), d.get('estimate')))")
  echo "$1 eps$2 $t $r"
 done
done
