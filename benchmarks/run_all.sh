#!/usr/bin/env bash
# Run every benchmark (serially and on 2 MPI ranks) and write benchmarks/results/.
# Called by `make benchmarks`; takes about 10-20 minutes on a 2-core machine.
# QUICK=1 runs only small meshes (a smoke run).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PY=.venv/bin/python
MPIEXEC=.venv/bin/mpiexec
export OMP_NUM_THREADS=1
quick=${QUICK:+--quick}
mkdir -p benchmarks/results

echo "== time stepping: cost and error against dofs (1 and 2 ranks)"
rm -f benchmarks/results/timestep.csv
$PY benchmarks/bench_timestep.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_timestep.py $quick
$PY benchmarks/summarize.py timestep

echo "== contact: Hertz 2D error/time, PDAS iterations, PDAS vs SNES VI (1 and 2 ranks)"
rm -f benchmarks/results/hertz.csv benchmarks/results/hertz_steps.csv benchmarks/results/hertz_vi.csv benchmarks/results/hertz3d.csv
$PY benchmarks/bench_hertz.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_hertz.py $quick
$PY benchmarks/summarize.py hertz hertz_steps hertz_vi hertz3d

echo "== friction: Cattaneo-Mindlin error/time, PDAS iterations vs mu and mesh, previous_step vs fixed_point"
rm -f benchmarks/results/friction.csv
$PY benchmarks/bench_friction.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_friction.py --quick
$PY benchmarks/summarize.py friction

echo "== 3D friction: semi-smooth Newton slip rows vs the slip-direction fixed point"
rm -f benchmarks/results/friction3d.csv
$PY benchmarks/bench_friction3d.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_friction3d.py --quick
$PY benchmarks/summarize.py friction3d

echo "== mortar geometry: 3D interface build against one linear solve (1 and 2 ranks)"
rm -f benchmarks/results/mortar.csv
$PY benchmarks/bench_mortar.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_mortar.py $quick

echo "== 3D load-driven contact at scale: phases, iterations, memory (default sizes 25k, 65k dofs; 1 and 2 ranks)"
rm -f benchmarks/results/contact3d.csv
$PY benchmarks/bench_contact3d.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_contact3d.py $quick
$PY benchmarks/summarize.py contact3d

echo "== inexact PDAS: Krylov iterations and time of the iterative 3D contact solve, tight vs loose tolerance (1 and 2 ranks)"
rm -f benchmarks/results/krylov3d.csv
$PY benchmarks/bench_krylov3d.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_krylov3d.py --quick

echo "== dynamic contact: two-bar impact error and energy drift against dt"
$PY benchmarks/bench_impact.py $quick

echo "== fracture: K error against dofs and time, kink angles, cost of a propagation increment"
rm -f benchmarks/results/fracture.csv benchmarks/results/fracture_direction.csv benchmarks/results/fracture_increment.csv
$PY benchmarks/bench_fracture.py $quick
echo "== 3D crack front: penny-crack K_I error against dofs and time"
rm -f benchmarks/results/front3d.csv
$PY benchmarks/bench_front3d.py $quick
echo "== 3D crack in a scene: inclined penny K_I/K_II/K_III error against dofs and time"
rm -f benchmarks/results/crack_scene3d.csv
$PY benchmarks/bench_crack_scene3d.py $quick
echo "== 3D crack growth in a scene: cost per increment (re-mesh, contact solve, K) against one linear solve, K_I error (1 and 2 ranks)"
rm -f benchmarks/results/crack_growth3d.csv
$PY benchmarks/bench_crack_growth3d.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_crack_growth3d.py --quick
$PY benchmarks/summarize.py crack_growth3d

echo "== checkpoints: write time, size and restart read time against a step (1 and 2 ranks)"
rm -f benchmarks/results/checkpoint.csv
$PY benchmarks/bench_checkpoint.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_checkpoint.py $quick

echo "== contact robustness matrix: every configuration of the covering design on 1, 2 and 3 ranks (outcome, PDAS iterations, time; ranks compared)"
rm -rf benchmarks/results/robustness.csv "${TMPDIR:-/tmp}/bonecontact-robustness"
$PY benchmarks/bench_robustness.py $quick
$MPIEXEC -n 2 $PY benchmarks/bench_robustness.py --compare $quick
$MPIEXEC -n 3 $PY benchmarks/bench_robustness.py --compare $quick
$PY benchmarks/bench_robustness.py --table

# further studies (growth) add their scripts here
for extra in benchmarks/bench_tumour.py benchmarks/bench_cyst.py; do
  if [ -f "$extra" ]; then echo "== $extra"; $PY "$extra" $quick; fi
done
echo "== 3D tumour growth: cost per step against cells, by phase"
$PY benchmarks/bench_tumour.py --study3d $quick
echo "== 3D coupled scenes: phases (meshing, growth, rebuild, mechanics) against mesh size; Lame cavity error"
rm -f benchmarks/results/scene3d.csv
for c in jaw_block mandible vertebra lame knee; do  # one process per case: its own peak memory
  $PY benchmarks/bench_scene3d.py --cases $c $quick
done
echo "== results in benchmarks/results/"
