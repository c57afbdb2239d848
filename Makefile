# fftnav: every target that needs the environment depends on .venv/.installed,
# so `make test` or `make benchmark` alone sets everything up on a fresh machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install install-browser install-learn test lint benchmark bench figures collab drift \
	replays leaderboard references evaluate-time learn clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,marl,fast,video,ros]'
	touch $(STAMP)

# The extra `learn` (fftnav learn: Stable-Baselines3 and torch) for `make learn`, not for `make
# install` or `make test`. Torch comes from PyTorch's CPU index first (PyPI's default wheel
# brings several GB of CUDA libraries this CPU-only training never uses); where that index
# cannot be reached, name a CPU wheel: make learn TORCH=/path/to/torch-X+cpu-....whl
TORCH ?= torch --index-url https://download.pytorch.org/whl/cpu
LEARN_STAMP := $(VENV)/.learn-installed

install-learn: $(LEARN_STAMP)

$(LEARN_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet $(TORCH)
	$(BIN)/python -m pip install --quiet -e '.[learn]'
	touch $(LEARN_STAMP)

# Headless Chromium from Debian's package, for the HTML replay player's browser test
# (tests/report/test_replay_browser.py; skipped without it, except in CI); sudo unless root.
SUDO := $(if $(filter 0,$(shell id -u)),,sudo)
install-browser:
	command -v chromium >/dev/null || { $(SUDO) apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium; }

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --doctest-modules fftnav tests

lint: $(STAMP)
	$(BIN)/ruff check fftnav tests experiments

benchmark: $(STAMP)
	$(BIN)/fftnav run experiments/table1.toml --out results/table1

# collab: the core comparison (walls, traps; own-only, fusion, collab; 20 maps), its walls
# holdouts (maps 21-40 and 41-60), the fresh maps 61-80 of every kind (with and without lidar
# noise; which robots fail there, and where their time went, also with 240 s), two robots
# head-on in a corridor, and the full sweep (docs/experiments.md, [sweep]); the runs resume
# when rerun.
collab: $(STAMP)
	$(BIN)/fftnav run experiments/collab/core.toml
	$(BIN)/fftnav figure sweep experiments/collab/core.toml
	$(BIN)/fftnav run experiments/collab/walls_holdout.toml
	$(BIN)/fftnav figure sweep experiments/collab/walls_holdout.toml
	$(BIN)/fftnav run experiments/collab/walls_fresh.toml
	$(BIN)/fftnav figure sweep experiments/collab/walls_fresh.toml
	$(BIN)/fftnav run experiments/collab/fresh.toml
	$(BIN)/fftnav figure sweep experiments/collab/fresh.toml
	$(BIN)/fftnav run experiments/collab/fresh_noise.toml
	$(BIN)/fftnav figure sweep experiments/collab/fresh_noise.toml
	$(BIN)/python experiments/headon.py
	$(BIN)/python experiments/noise_seeds.py
	$(BIN)/python experiments/walls_failures.py
	$(BIN)/python experiments/time_budget.py results/collab/fresh
	$(BIN)/fftnav run experiments/collab/fresh_noise_240.toml
	$(BIN)/python experiments/time_budget.py results/collab/fresh_noise_240
	$(BIN)/fftnav run experiments/collab.toml

# drift: every built-in method without external positioning (docs/localization.md): the
# odometry presets on Table I's maps and on fresh walls and traps maps (2,560 episodes, about
# 80 min with 2 workers), their Holm-adjusted gains, and the drift report beside the exact runs.
drift: $(STAMP)
	$(BIN)/fftnav bench drift --csv results/drift/calibration.csv
	$(BIN)/fftnav run experiments/drift/table1.toml
	$(BIN)/fftnav figure sweep experiments/drift/table1.toml
	$(BIN)/fftnav run experiments/drift/fresh.toml
	$(BIN)/fftnav figure sweep experiments/drift/fresh.toml
	$(BIN)/fftnav figure drift experiments/drift/table1.toml experiments/drift/fresh.toml \
		--exact results/baselines results/collab/table1 results/collab/fresh --out results/drift

# learn: the reference training of docs/learning.md (three controller observations and the
# decider, three seeds each, two at a time; about 80 min on a 2-core machine), then the
# trained networks on Table I's maps beside the built-ins, into results/learned/; resumes.
learn: $(LEARN_STAMP)
	$(BIN)/python experiments/learn/reference.py --workers 2

bench: $(STAMP)
	$(BIN)/fftnav bench pipeline --csv results/pipeline_latency.csv
	$(BIN)/fftnav bench sim --env forest --csv results/sim_speed.csv
	$(BIN)/fftnav bench sim --env rocky --csv results/sim_speed.csv --append
	$(BIN)/fftnav bench worlds --csv results/large_worlds.csv
	$(BIN)/fftnav bench env --csv results/env_speed.csv
	$(BIN)/fftnav bench bag --csv results/bag_speed.csv
	$(BIN)/fftnav bench scale

figures: $(STAMP)
	$(BIN)/fftnav figure filters --out results/figures
	$(BIN)/fftnav figure depth3d --out results/figures

# replays: the README's GIF and docs/analysis.md's frame per cause of failure, from recordings
# made on demand: each episode rerun from its committed folder (results/table1,
# results/collab/core, results/collab/fresh), its rows checked against that folder's
# episodes.csv first (`fftnav replay RESULTS_DIR --task TASK`).
replays: $(STAMP)
	$(BIN)/python experiments/replay_figures.py

# leaderboard: every built-in on every versioned suite (fftnav suites), from the reference rows
# the package ships, and the methods added with `fftnav leaderboard add`: results/leaderboard/.
leaderboard: $(STAMP)
	$(BIN)/fftnav leaderboard build --out results/leaderboard

# references (maintainers): rerun every built-in on every suite (about an hour on 2 cores,
# resumable) and write the package's reference rows, fftnav/suites/references/.
references: $(STAMP)
	$(BIN)/fftnav suites --references --runs build/suite-runs

# evaluate-time: the README's controller through `fftnav evaluate --suite paper-v2` and
# `make benchmark`'s run, side by side: results/evaluate_time.csv.
evaluate-time: $(STAMP)
	$(BIN)/python experiments/evaluate_time.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
