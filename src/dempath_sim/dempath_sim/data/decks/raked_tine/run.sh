#!/bin/sh
# Run the raked-tine bin on LIGGGHTS 3.8: the leaning-tine deck's run.sh with this folder's files.
#   run.sh SEED VARIANT OUTDIR [NP]   (see ../leaning_tine/run.sh)
here=$(cd "$(dirname "$0")" && pwd)
DECK=$here exec sh "$here/../leaning_tine/run.sh" "$@"
