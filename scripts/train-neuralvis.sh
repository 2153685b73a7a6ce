#!/usr/bin/env bash
# Trains the learned visibility method (`neuralvis`) from nothing, reproducibly, in one command:
#   1. a Python environment of its own (.venv-train: PyTorch and ocnn from PyPI, pinned; the
#      Linux torch wheel pulls several GB of CUDA packages it never uses here),
#   2. the labels of our ground truth on the training meshes
#      (crates/harness/examples/neuralvis_data.rs, seeded; the meshes are fetched and checked),
#   3. the training (scripts/neuralvis/train.py: checkpointed, resumable: run the same command
#      again after a stop and it goes on where it stopped),
#   4. with --install, the weights file and its training record copied to
#      crates/neuralvis/weights/ (what the Rust method loads by default).
#
# Usage: scripts/train-neuralvis.sh [--seed S] [--steps N] [--run DIR] [--install]
#                                   [--smoke] [-- extra train.py arguments]
# --smoke: two tiny meshes' worth of data and a few steps (the opt-in smoke test's run).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seed=66
steps=1000
run=""
install=0
smoke=0
extra=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --seed) seed="$2"; shift 2 ;;
        --steps) steps="$2"; shift 2 ;;
        --run) run="$2"; shift 2 ;;
        --install) install=1; shift ;;
        --smoke) smoke=1; shift ;;
        --) shift; extra=("$@"); break ;;
        *) echo "unknown argument: $1" >&2; exit 2 ;;
    esac
done

venv="$root/.venv-train"
if [[ ! -x "$venv/bin/python" ]] || ! "$venv/bin/python" -c "import ocnn, torch" 2>/dev/null; then
    avail_gb=$(df -Pk "$root" | awk 'NR==2 {print int($4 / 1048576)}')
    if (( avail_gb < 22 )); then
        echo "only ${avail_gb} GB free: PyTorch's wheel and its CUDA packages need about 6 GB" \
             "and the disk should keep 15 GB free" >&2
        exit 1
    fi
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q --no-cache-dir --upgrade pip
    "$venv/bin/pip" install -q --no-cache-dir "torch==2.15.0" "ocnn==2.3.3" numpy
fi

data_args=(--seed "$seed")
if (( smoke )); then
    data="$root/bench-data/neuralvis-data-smoke"
    data_args+=(--limit 1 --clouds 2)
    run="${run:-$root/bench-data/neuralvis-run-smoke}"
else
    data="$root/bench-data/neuralvis-data"
    run="${run:-$root/bench-data/neuralvis-run-$seed}"
fi
if [[ ! -f "$data/manifest.json" ]]; then
    cargo run -q --release -p harness --example neuralvis_data -- --out "$data" "${data_args[@]}"
fi

"$venv/bin/python" "$root/scripts/neuralvis/train.py" --data "$data" --out "$run" \
    --seed "$seed" --steps "$steps" "${extra[@]}"

if (( install )); then
    shopt -s nullglob
    files=("$run"/neuralvis-*.nvw)
    if (( ${#files[@]} != 1 )); then
        echo "no finished run in $run to install" >&2
        exit 1
    fi
    name="$(basename "${files[0]}" .nvw)"
    cp "$run/$name.nvw" "$root/crates/neuralvis/weights/neuralvis.nvw"
    cp "$run/$name.training.json" "$root/crates/neuralvis/weights/neuralvis.training.json"
    echo "installed $name into crates/neuralvis/weights/"
fi
