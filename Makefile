# Two entry points: `make demo` (the main job) and `make test`. Both set up what is missing.
VENV   ?= .venv
PY     := $(VENV)/bin/python
FKEV   := $(VENV)/bin/fkev
NP     ?= 2
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1

.PHONY: setup demo test figures clean
setup:
	@bash scripts/setup.sh $(VENV)

demo: setup
	@bash scripts/demo.sh $(VENV) $(NP)

test: setup
	@$(PY) -m pytest -q tests

figures: setup
	@bash scripts/figures.sh $(VENV)

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
