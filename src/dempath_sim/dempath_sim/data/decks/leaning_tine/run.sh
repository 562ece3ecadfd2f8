#!/bin/sh
# Run the leaning-tine bin (or the deck in $DECK, e.g. ../raked_tine) on LIGGGHTS 3.8: settle a
# bed for a seed (if not done) and drive the tine through it with one physics variant.
#   run.sh SEED VARIANT OUTDIR [NP]     SEED 1-8, VARIANT a physics_VARIANT.in of this folder
#   (base, rolling, cohesion, tool_friction, particle_friction, youngs_modulus, restitution,
#   tool_speed), NP MPI ranks (2)
# Writes OUTDIR/seed<SEED>/bed.data (shared by the variants) and OUTDIR/seed<SEED>/<VARIANT>/
# (start.dump, top.dump, end.dump, tine_force.txt, logs). Needs liggghts and mpirun on PATH.
set -eu
seed=$1; variant=$2; out=$3; np=${4:-2}
deck=${DECK:-$(cd "$(dirname "$0")" && pwd)}  # DECK: another deck folder of the same files
# LIGGGHTS wants prime random seeds above 10,000: two per packing seed.
case $seed in
  1) p1=15485863; p2=32452843 ;;  2) p1=49979687; p2=67867967 ;;
  3) p1=86028121; p2=104395301 ;; 4) p1=122949823; p2=141650939 ;;
  5) p1=160481183; p2=179424673 ;; 6) p1=198491317; p2=217645177 ;;
  7) p1=236887691; p2=256203161 ;; 8) p1=275604541; p2=295075147 ;;
  *) echo "error: seed: $seed: use 1-8" >&2; exit 2 ;;
esac
[ -f "$deck/physics_$variant.in" ] || {
  echo "error: variant: $variant: no physics_$variant.in in $deck" >&2; exit 2; }
mpi="mpirun --allow-run-as-root --oversubscribe -np $np"
mkdir -p "$out/seed$seed/$variant"
cd "$out/seed$seed"
if [ ! -f bed.data ]; then
  $mpi liggghts -echo none -log log.settle -var deck "$deck" -var seed $p1 -var seed2 $p2 \
    -in "$deck/in.settle" > settle.out
fi
cd "$variant"
cp ../bed.data bed.data
$mpi liggghts -echo none -log log.pass -var deck "$deck" -var variant "$variant" \
  -in "$deck/in.pass" > pass.out
rm bed.data
