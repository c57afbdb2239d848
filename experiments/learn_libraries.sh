#!/usr/bin/env bash
# Install cost of each candidate RL library for `fftnav learn`, measured on a fresh
# venv per candidate, outside the repository:
#
#   bash experiments/learn_libraries.sh [ROOT]      # ROOT default /tmp/fftnav-learn-libraries
#
# For each candidate: an empty venv (pip upgraded, not timed), then `pip download` of fftnav's
# wheel with its `marl` and `fast` extras and the candidate's packages into a fresh folder (the
# download: its time and the folder's size), then `pip install --no-index` from that folder
# (the install). No pip cache is used, so every figure is a fresh machine's. The venvs stay in
# ROOT/venvs/NAME for the throughput measurement of experiments/learn_libraries.py, which reads
# ROOT/installs.csv (one row per candidate: name, download_s, install_s, download_mb,
# venv_mb, empty_venv_mb, status) and writes results/learn_libraries.csv.
#
# Candidates (a row is written even when one fails, its status saying where):
#   base        fftnav[marl,fast] alone: the part every candidate shares
#   sb3-cuda    stable-baselines3 + supersuit, torch from PyPI (its default wheel, CUDA libraries)
#   sb3-cpu     stable-baselines3 + supersuit, torch from download.pytorch.org/whl/cpu
#   skrl-jax    skrl + jax[cpu] (with flax and optax, skrl's JAX backend)
#   torchrl-cpu torchrl + tensordict + benchmarl, torch from download.pytorch.org/whl/cpu
# Run a subset with CANDIDATES="base sb3-cpu" bash experiments/learn_libraries.sh.
# Where download.pytorch.org is unreachable, CPU_TORCH_WHEEL=/path/torch-X+cpu-....whl takes the
# CPU wheel from that file instead (copied into the download folder: its size counts, its copy
# time is not a download's). pip's own configuration (pip.conf, local find-links, constraints)
# is switched off, so every package comes from PyPI (and the CPU index).
set -u
export PIP_CONFIG_FILE=/dev/null
unset PIP_FIND_LINKS PIP_INDEX_URL PIP_EXTRA_INDEX_URL PIP_CONSTRAINT
ROOT=${1:-/tmp/fftnav-learn-libraries}
PY=${PYTHON:-python3}
HERE=$(cd "$(dirname "$0")/.." && pwd)
CPU_INDEX=https://download.pytorch.org/whl/cpu
CANDIDATES=${CANDIDATES:-"base sb3-cpu skrl-jax torchrl-cpu sb3-cuda"}
mkdir -p "$ROOT/venvs" "$ROOT/wheels" "$ROOT/logs"

# fftnav's wheel, built from the committed tree (git archive HEAD), so the working tree is untouched
if [ ! -f "$ROOT/fftnav_wheel/done" ]; then
    rm -rf "$ROOT/src" "$ROOT/fftnav_wheel" && mkdir -p "$ROOT/src" "$ROOT/fftnav_wheel"
    git -C "$HERE" archive HEAD | tar -x -C "$ROOT/src"
    "$PY" -m pip wheel --quiet --no-deps --no-cache-dir -w "$ROOT/fftnav_wheel" "$ROOT/src" \
        && touch "$ROOT/fftnav_wheel/done"
fi
FFTNAV=$(ls "$ROOT"/fftnav_wheel/fftnav-*.whl)
BASE="${FFTNAV}[marl,fast]"

packages() {  # the candidate's pip arguments (beside fftnav)
    case $1 in
        base) echo "" ;;
        sb3-cuda) echo "stable-baselines3 supersuit" ;;
        sb3-cpu) echo "stable-baselines3 supersuit" ;;
        skrl-jax) echo "skrl[jax] jax[cpu] flax optax" ;;
        torchrl-cpu) echo "torchrl tensordict benchmarl" ;;
    esac
}
cpu_torch() { [ "$1" = sb3-cpu ] || [ "$1" = torchrl-cpu ]; }

mb() { du -sm "$1" | cut -f1; }
now() { date +%s.%N; }
[ -f "$ROOT/installs.csv" ] || echo "name,download_s,install_s,download_mb,venv_mb,empty_venv_mb,status" > "$ROOT/installs.csv"

for name in $CANDIDATES; do
    venv=$ROOT/venvs/$name wheels=$ROOT/wheels/$name log=$ROOT/logs/$name.log
    rm -rf "$venv" "$wheels" && mkdir -p "$wheels"
    "$PY" -m venv "$venv" && "$venv/bin/pip" install --quiet --no-cache-dir --upgrade pip >"$log" 2>&1
    empty=$(mb "$venv")
    status=ok
    t0=$(now)
    if cpu_torch "$name"; then
        # torch from the CPU index first; the rest from PyPI, held to that very torch
        if [ -n "${CPU_TORCH_WHEEL:-}" ]; then
            cp "$CPU_TORCH_WHEEL" "$wheels/" || status=download_failed
        else
            "$venv/bin/pip" download --no-cache-dir -d "$wheels" --index-url "$CPU_INDEX" torch >>"$log" 2>&1 || status=download_failed
        fi
        tv=$(ls "$wheels" | sed -n 's/^torch-\([^-]*\)-.*/\1/p' | head -1)
        echo "torch==${tv//%2B/+}" > "$ROOT/wheels/$name.constraints"
        CONSTRAINT=(-c "$ROOT/wheels/$name.constraints" --find-links "$wheels")
    else
        CONSTRAINT=()
    fi
    # shellcheck disable=SC2046
    [ $status = ok ] && { "$venv/bin/pip" download --no-cache-dir -d "$wheels" "${CONSTRAINT[@]}" "$BASE" $(packages "$name") >>"$log" 2>&1 || status=download_failed; }
    t1=$(now)
    # shellcheck disable=SC2046
    [ $status = ok ] && { "$venv/bin/pip" install --no-cache-dir --no-index --find-links "$wheels" "${CONSTRAINT[@]}" "$BASE" $(packages "$name") >>"$log" 2>&1 || status=install_failed; }
    t2=$(now)
    "$venv/bin/pip" freeze > "$ROOT/logs/$name.freeze" 2>/dev/null
    row=$(printf '%s,%.1f,%.1f,%s,%s,%s,%s' "$name" "$(echo "$t1 - $t0" | bc)" "$(echo "$t2 - $t1" | bc)" \
        "$(mb "$wheels")" "$(mb "$venv")" "$empty" "$status")
    echo "$row" >> "$ROOT/installs.csv"
    echo "$row"
done
