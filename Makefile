# make run        set up what a race needs, then race the simulated car round a track; print the laps, plot
# make test       set up everything, then run the whole suite (the 20 slowest tests listed at the end)
# make setup      set up everything `make test` needs (Debian packages, npm runtimes, .venv with every extra)
# make setup-run  set up only what a race needs (.venv with the simulator, a C++ compiler)
# make trace      set up what a race needs, then drive the firmware logic through a scripted session; plot
# make bench      set up, then print the benchmarks
# make fuzz       set up, then fuzz every target for minutes, the corpora grown and minimised into fuzz/corpus
# make gen        regenerate protocol files from protocol/spec.toml
# make core       build the firmware core for this machine, plain and sanitized, into build/host
# make firmware   build the Nano and AnyFC F7 firmware offline; print flash/RAM per target
# make deploy BOARD=junior|car [PORT=...]            MicroPython program onto a board (mpremote)
# make flash-micropython IMAGE=file.bin [PORT=...]   MicroPython itself onto an ESP32 (esptool)
# make upload ENV=nanoatmega328 [PORT=...]           a C++ board through PlatformIO
# make clean      remove build outputs, out/ and the test caches
.PHONY: setup setup-run run trace test bench fuzz gen core firmware deploy flash-micropython upload clean

PY := .venv/bin/python

# everything `make test` needs (the cross toolchains, the emulators, every Python extra)
setup:
	@bash scripts/setup.sh test

# only what a race needs: the venv with the simulator and a C++ compiler for the firmware core
setup-run:
	@bash scripts/setup.sh run

run: setup-run
	@.venv/bin/roar race --track oval --laps 3 --plot out/race.png

trace: setup-run
	@$(PY) -m roar_sim.runs.scripted_drive --plot out/scripted_drive.png

# The suite on every core and one worker more (TEST_WORKERS=N to choose; 0: in this process alone):
# realtime tests run one at a time on one worker (tests/README.md), which mostly waits on the wall
# clock, so the others fill every core; the 20 slowest listed at the end. pytest exits 5 when it
# collects no tests; that is a failure of the suite, not a pass.
test: setup
	@$(PY) -m pytest -q -n $(or $(TEST_WORKERS),$(shell echo $$(( $$(nproc) + 1 )))) --dist loadgroup --durations=20; rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "no tests collected"; exit 1; fi; exit $$rc

bench: setup
	@$(PY) -m benchmarks

# FUZZ_SECONDS=120 per target by default; the suite runs each for 2 s (tests/firmware/test_fuzz.py)
fuzz: setup
	@$(PY) -m fuzz run --seconds $(or $(FUZZ_SECONDS),120)

gen: setup
	@$(PY) protocol/generate.py

core: setup-run
	@$(PY) -m roar_sim.toolchains.native --variant release
	@$(PY) -m roar_sim.toolchains.native --variant sanitize

firmware: setup
	@$(PY) -m roar_sim.toolchains.avr
	@$(PY) -m roar_sim.toolchains.arm
	@$(PY) -m roar_sim.toolchains.sizes

PORT_ARG = $(if $(PORT),--port $(PORT),)

deploy: setup
	@$(PY) firmware/deploy.py micropython "$(BOARD)" $(PORT_ARG)

flash-micropython: setup
	@$(PY) firmware/deploy.py micropython-image "$(IMAGE)" $(PORT_ARG)

upload: setup
	@$(PY) firmware/deploy.py pio "$(ENV)" $(PORT_ARG)

clean:
	rm -rf build out .pytest_cache .hypothesis
