#!/usr/bin/env bash
# The FEM speed comparison of docs/BENCHMARKS.md ("## FEM"): the seed001 bench (Rust, this
# crate's pipeline) against CHOLMOD (scikit-sparse), PARDISO (pypardiso, MKL), SuperLU
# (SciPy, for continuity with the older tables) on the very matrix the bench exports, and a
# scikit-fem pipeline (assembly to top stresses) on the exported mesh; run in alternation
# over several rounds at each thread count, with the Rust bench's peak memory at two levels.
#
#   scripts/fem_compare.sh            (env: ROUNDS=5 REFINE=3 THREADS="1 2" MEM_REFINES="3 5"
#                                      OUT=$CARGO_TARGET_DIR/fem-compare SUPERLU=1 SKFEM=1)
#
# Sets up its own Python venv in $OUT/venv (pip: numpy, scipy, pypardiso, scikit-sparse,
# scikit-fem). scikit-sparse has no wheel and compiles against SuiteSparse's CHOLMOD: when
# its build fails and this runs as root with apt-get, the script installs the Debian
# packages libsuitesparse-dev and libopenblas0-pthread (CHOLMOD's supernodal factorization
# with the reference BLAS would be a strawman) and tries again. Only this benchmark needs
# them; the project's build and tests do not. Every build and run is under `nice -n 10` (the
# machine is shared). Results: $OUT/results.jsonl (one JSON line per measurement) and the
# median table on stdout.
set -euo pipefail
cd "$(dirname "$0")/.."
ROUNDS="${ROUNDS:-5}"
REFINE="${REFINE:-3}"
THREADS="${THREADS:-1 2}"
MEM_REFINES="${MEM_REFINES:-3 5}"
SUPERLU="${SUPERLU:-1}"
SKFEM="${SKFEM:-1}"
OUT="${OUT:-${CARGO_TARGET_DIR:-target}/fem-compare}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
PY="$OUT/venv/bin/python"
HERE="$(pwd)/scripts"

# --- The Python side.
if [ ! -x "$PY" ]; then python3 -m venv "$OUT/venv"; fi
nice -n 10 "$PY" -m pip install -q numpy scipy pypardiso scikit-fem
# scikit-sparse 0.5 needs SuiteSparse >= 7; 0.4.x builds against 5.x (Debian 12 ships 5.12).
sksparse() { nice -n 10 "$PY" -m pip install -q scikit-sparse || nice -n 10 "$PY" -m pip install -q 'scikit-sparse<0.5'; }
if ! "$PY" -c 'import sksparse.cholmod' 2>/dev/null && ! sksparse; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "fem_compare: scikit-sparse needs SuiteSparse; installing libsuitesparse-dev"
        apt-get update -q
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
            libsuitesparse-dev libopenblas0-pthread
        sksparse
    else
        echo "fem_compare: scikit-sparse did not build; install SuiteSparse (libsuitesparse-dev) and retry" >&2
        exit 1
    fi
fi

# --- The Rust side.
B=$(nice -n 10 cargo bench -p pulsetrack-fem --bench seed001 --no-run 2>&1 |
    sed -n 's/.*Executable.*(\(.*\))/\1/p')
[ -x "$B" ] || { echo "fem_compare: no bench executable" >&2; exit 1; }
RES="$OUT/results.jsonl"
{
    echo "# $(date -u +%FT%TZ) $(uname -srm), $(nproc) cores, load: $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "# $(rustc -V); $("$PY" -V)"
    "$PY" "$HERE/fem_compare.py" versions | sed 's/^/# /'
    readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 2>/dev/null | sed 's/^/# libblas.so.3 -> /' || true
    dpkg-query -W libcholmod3 libsuitesparse-dev libopenblas0-pthread 2>/dev/null | sed 's/^/# deb /' || true
} >"$RES"
nice -n 10 "$B" --refine "$REFINE" --reps 1 --export "$OUT/export" >/dev/null
"$PY" "$HERE/fem_compare.py" prepare "$OUT/export"

# Peak resident memory of the whole bench process (mesh, K, factor, solve, recovery).
for level in $MEM_REFINES; do
    /usr/bin/time -v nice -n 10 "$B" --refine "$level" --reps 1 2>"$OUT/time-$level.txt" |
        tail -1 >"$OUT/row-$level.txt"
    kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$OUT/time-$level.txt")
    dofs=$(awk '{print $2}' "$OUT/row-$level.txt")
    echo "{\"side\": \"rust-memory\", \"refine\": $level, \"dofs\": $dofs, \"peak_rss_mib\": $((kb / 1024)), \"threads\": {}}" >>"$RES"
done

for round in $(seq 1 "$ROUNDS"); do
    echo "fem_compare: round $round of $ROUNDS (load $(cut -d' ' -f1 /proc/loadavg))" >&2
    for t in $THREADS; do
        export RAYON_NUM_THREADS=$t MKL_NUM_THREADS=$t OMP_NUM_THREADS=$t OPENBLAS_NUM_THREADS=$t
        for o in split node nd; do
            nice -n 10 "$B" --refine "$REFINE" --reps 3 --ordering "$o" |
                "$PY" "$HERE/fem_compare.py" rust --ordering "$o" --reps 3 >>"$RES"
        done
        lu=()
        if [ "$SUPERLU" = 1 ] && [ "$t" = "$(echo $THREADS | cut -d' ' -f1)" ]; then lu=(--superlu); fi
        nice -n 10 "$PY" "$HERE/fem_compare.py" solvers "$OUT/export" --reps 3 "${lu[@]}" >>"$RES"
        if [ "$SKFEM" = 1 ]; then
            nice -n 10 "$PY" "$HERE/fem_compare.py" skfem "$OUT/export" --reps 1 >>"$RES"
        fi
    done
done
echo "# end $(date -u +%FT%TZ), load: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$RES"
grep '^#' "$RES"
grep rust-memory "$RES"
"$PY" "$HERE/fem_compare.py" summary "$RES"
