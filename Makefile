# The two commands of the README, and their parts. Every target installs what it needs.
#   make demo   bake the thesis's demo scene (progress bar), say where the output is
#   make test   formatting, lints, every test, the Embree 4 header check, the independent reference
#   make bench  the bake benchmark against the raw Embree rate (docs/performance.md)

CARGO ?= cargo
BAKE := target/release/prt-bake
SCENE := scenes/torus/torus.scene

.PHONY: demo test bench deps build lint unit embree4 reference scenes

deps:
	@scripts/install-deps.sh

build: deps
	$(CARGO) build --release --workspace

demo: build
	@mkdir -p out
	$(BAKE) bake $(SCENE) -o out/torus.prt --samples 10000
	$(BAKE) export out/torus.prt --scene $(SCENE) --npz out/torus.npz
	@echo
	@echo "demo: coefficients in out/torus.prt (header: $(BAKE) inspect out/torus.prt),"
	@echo "      NumPy arrays (positions, normals, albedo, transfer) in out/torus.npz"

lint: deps
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets --release -- -D warnings

unit: deps
	$(CARGO) test --workspace --release

embree4: deps
	scripts/check-embree4.sh

reference: build
	scripts/reference/run.sh

test: lint unit embree4 reference

bench: deps
	$(CARGO) bench -p prt-baker --bench bake

# Regenerates the committed demo scenes (a test checks they match the generator).
scenes:
	$(CARGO) run --release -p prt-scenes
