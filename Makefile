# The two set-up commands of the README, plus the longer jobs.
# Each installs what it needs (scripts/install-deps is idempotent).
.PHONY: demo test bench fuzz package clean

demo:            ## calibrate the default scene and play it on the simulated device
	scripts/demo

test:            ## build and run every test (default, asan, tsan, fuzz, cross, virtual board, packages)
	scripts/test

bench:           ## micro-benchmarks and studies (long; figures go to docs/BENCHMARKS.md)
	scripts/bench

fuzz:            ## longer fuzzing run: table reader, host trigger and board parsers (10 min per harness)
	scripts/fuzz 600

package:         ## Debian packages (hapticd, calibgen) in out/packages/
	scripts/package

clean:
	rm -rf build out
