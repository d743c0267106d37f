# Two entry points on a fresh machine: `make demo` and `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
OUT ?= gc_ocp_demo_output

.PHONY: demo test lint bench clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.installed: pyproject.toml constraints.txt | $(BIN)/python
	$(BIN)/python -m pip install -q -c constraints.txt -e '.[dev]'
	touch $@

demo: $(VENV)/.installed
	$(BIN)/gc-ocp info
	$(BIN)/gc-ocp kinematics --out $(OUT)/kinematics
	$(BIN)/gc-ocp fit --holdout right@0.407 --out $(OUT)/fit
	$(BIN)/gc-ocp reproduce-seed --seeds 5 --out $(OUT)/seed
	$(BIN)/gc-ocp diagnose --out $(OUT)/diagnosis
	$(BIN)/gc-ocp export opensim $(OUT)/fit/fit.json --out $(OUT)/opensim
	$(BIN)/gc-ocp export casadi $(OUT)/fit/fit.json --out $(OUT)/contact.casadi
	@echo "Demo output written to $(abspath $(OUT))"
	@echo "Diagnosis report: $(abspath $(OUT))/diagnosis/report.html (open it in a browser)"

test: lint
	$(BIN)/python -m pytest -q -n auto --dist loadscope -W error::RuntimeWarning

lint: $(VENV)/.installed
	$(BIN)/ruff format --check .
	$(BIN)/ruff check .

bench: $(VENV)/.installed
	$(BIN)/python benchmarks/fit_speed.py

clean:
	rm -rf $(VENV) $(OUT)
