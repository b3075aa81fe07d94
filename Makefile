PYTHON ?= python3

.PHONY: install demo test lint bench

install:
	$(PYTHON) -m pip install -q -e '.[test]'
	-$(PYTHON) -m streamline_cam.cli warm-up

demo: install
	toolpath demo

lint:
	$(PYTHON) -m ruff check .

test: install lint
	scripts/install-chromium
	$(PYTHON) -m pytest -n 2 --dist loadfile

bench:
	$(PYTHON) -m pip install -q -e '.[test,bench]'
	$(PYTHON) benchmarks/paper_tables.py
	$(PYTHON) benchmarks/bench_fit.py
	$(PYTHON) benchmarks/bench_toolpath.py
	$(PYTHON) benchmarks/bench_simulator.py
	$(PYTHON) benchmarks/bench_stream.py
	$(PYTHON) benchmarks/bench_gcode.py
	$(PYTHON) benchmarks/bench_verify.py
	$(PYTHON) benchmarks/bench_batch.py
