# The two commands of the README, and their parts. Every target installs what it needs.
#   make demo        bake the thesis's demo scene (progress bar), then open the viewer on it, or
#                    without a display render PRT and Blinn-Phong screenshots and say where
#   make test        formatting, lints, every test, a build without Embree, the Embree 4 header
#                    check, the independent reference, a sharded bake on a real Slurm cluster
#   make interop     glTF export checked by the Khronos glTF-Validator, the Python .prt reader
#                    against the npz export, the EXR export against it (part of make test)
#   make mitsuba     interreflected vertex and texel bakes against Mitsuba 3, a path tracer
#                    (part of make test, 30 s to 2 min; docs/guides/lightmaps.md)
#   make mitsuba-subsurface  subsurface transfer against Mitsuba 3's volumetric path tracer
#                    (part of make test, about 30 s; docs/guides/subsurface.md)
#   make mitsuba-probes  interreflected transfer probes against Mitsuba 3 in the Cornell room
#                    (part of make test, about 15 s; docs/guides/probes.md)
#   make no-embree-full  every prt-baker test in the build without Embree (make test runs the
#                    baking command-line tests there)
#   make blender     a Blender glTF with per-object lightmap UVs against Cycles' AO bake
#                    (part of make test, about 30 s after a 373 MB install; docs/guides/lightmaps.md)
#   make blender-addon  the Blender add-on (runtime/blender/prt_bake): installed from its zip,
#                    baked through bpy.ops.prt.bake, against the CLI on Blender's export of the
#                    same scene; the production courtyard per vertex and per texel; a 1,000-
#                    instance scatter (part of make test, 45-60 s after make blender;
#                    docs/guides/blender.md)
#   make blender-production  the production-style courtyard (scenes/production: cut-out cards,
#                    a normal-mapped wall, linked-duplicate crates) against Cycles' AO bake
#                    (part of make test, about 20 s after make blender; docs/reference/scenes.md)
#   make blender-walker  the walking character (scenes/cornell/walker.glb) rebuilt by bpy equals
#                    the committed file byte for byte (part of make test, about 4 s)
#   make bench       the bake benchmark: Embree and obvhs against the raw Embree rate
#                    (docs/explanation/performance.md)
#   make bench-large how texel bakes scale: 1 M and 4 M triangles × 2048² and 4096² lightmaps,
#                    whole and in staged shards (scripts/bench/lightmap_scale.sh; about 10 CPU-min
#                    a 2048² cell at 1 M triangles, ~60 at 4 M × 4096², which peaks near 9 GB and
#                    holds ~9 GB of files; SCALE_CELLS=708:2048 runs one cell; docs/guides/clusters.md)
#   make fuzz        the parsers' mutation fuzzing from a newly drawn seed at 20 times make test's
#                    mutants (make test runs fixed seeds: docs/explanation/robustness.md)
#   make web GLB=F   serve the three.js example page for a prt-bake .glb and print its address
#   make docs-check  every command of the guides run on the repository's scenes, the docs' links
#                    (part of make test, about a minute; make cli-reference regenerates the CLI page)
#   make bench-view  the viewer's frame rates, Blinn-Phong and PRT with 1 and 8 lights, per vertex
#                    and per pixel (a texel bake), and the texel bake with 4 moving occluders
#                    (docs/explanation/performance.md)

CARGO ?= cargo
BAKE := target/release/prt-bake
VIEW := target/release/prt-view
SCENE := scenes/torus/torus.scene
# prt-bake without the `embree` feature, built in its own folder so the two builds do not
# invalidate each other.
NO_EMBREE := target/no-embree
NO_EMBREE_BAKE := $(NO_EMBREE)/release/prt-bake

# make mitsuba-subsurface: subsurface transfer against Mitsuba 3's volpath on fresh references
.PHONY: mitsuba-subsurface
# make mitsuba-probes: interreflected transfer probes against Mitsuba 3 on fresh references
.PHONY: mitsuba-probes
.PHONY: demo test bench bench-large bench-view deps build lint unit no-embree embree4 reference interop scenes slurm fuzz browser mitsuba blender web

deps:
	@scripts/install-deps.sh

build: deps
	$(CARGO) build --release --workspace

# The demo builds only the two programs it runs (make build, for make test, builds the
# workspace: the scene generator and the cross-crate tests' library too).
.PHONY: demo-build
demo-build: deps
	$(CARGO) build --release -p prt-baker -p prt-viewer --bins

out/torus.prt: demo-build
	@mkdir -p out
	$(BAKE) bake $(SCENE) -o out/torus.prt --samples 10000

# (Without a display, Vulkan's loader asks libwayland for a socket, which prints an error line
# where XDG_RUNTIME_DIR is unset: a private empty folder answers it quietly.)
demo: out/torus.prt
	$(BAKE) export out/torus.prt --scene $(SCENE) --npz out/torus.npz
	@echo
	@echo "demo: coefficients in out/torus.prt (header: $(BAKE) inspect out/torus.prt),"
	@echo "      NumPy arrays (positions, normals, albedo, transfer) in out/torus.npz"
	@if [ -n "$$DISPLAY" ]; then \
		echo "demo: opening the viewer (Escape quits; keys in README.md)"; \
		$(VIEW) $(SCENE) out/torus.prt; \
	else \
		if [ -z "$$XDG_RUNTIME_DIR" ]; then XDG_RUNTIME_DIR=$$(mktemp -d); export XDG_RUNTIME_DIR; fi; \
		$(VIEW) $(SCENE) out/torus.prt --headless --screenshot out/demo-prt.png --mode prt && \
		$(VIEW) $(SCENE) out/torus.prt --headless --screenshot out/demo-phong.png --mode phong && \
		echo "demo: no display (DISPLAY is unset), so no window; screenshots:" && \
		echo "      out/demo-prt.png    PRT" && \
		echo "      out/demo-phong.png  Blinn-Phong, the same lights"; \
	fi

# The crate's architecture: no import cycles between its files, no layer importing one above
# it (the order of baker/src/lib.rs; tests included), no file over 700 lines, main.rs at most
# 200; a thin command line: commands/bake.rs at most 300 lines (it only lowers its arguments
# into a plan), no function in commands/ over 80.
lint: deps
	python3 scripts/check-layers.py baker/src support,math,scene,trace,light,formats,bake,distribute,export,commands \
		--max-lines commands/bake.rs=300 --max-function-lines commands=80
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets --release -- -D warnings

unit: deps
	$(CARGO) test --workspace --release

# A build without Embree: embree-sys is not even in the dependency graph (so no Embree headers
# are needed), the binary does not link libembree, it bakes the demo scene with obvhs, and the
# command-line tests that bake (obvhs is then the default backend) pass. The unit tests and the
# other test files do not depend on the backend and already ran in `make unit`; `make
# no-embree-full` runs every prt-baker test in this build (it compiles the library's tests and
# links every test binary a second time, which is why make test does not).
NO_EMBREE_TESTS := --test cli --test cli_lightmap --test cli_receivers --test output_policy
no-embree: deps
	$(CARGO) test --release -p prt-baker --no-default-features --target-dir $(NO_EMBREE) $(NO_EMBREE_TESTS)
# (the command-line tests build $(NO_EMBREE_BAKE), the binary checked below: a separate `cargo
# build` would compile the dependencies a second time, under the features without dev-dependencies)
	@if $(CARGO) tree -p prt-baker --no-default-features -e normal,build,dev | grep embree; then \
		echo "no-embree: embree-sys is in the dependency graph"; exit 1; fi
	@if ldd $(NO_EMBREE_BAKE) | grep -i embree; then \
		echo "no-embree: $(NO_EMBREE_BAKE) links Embree"; exit 1; fi
	@mkdir -p out
	$(NO_EMBREE_BAKE) bake $(SCENE) -o out/torus-obvhs.prt --samples 1024 --quiet
	@$(NO_EMBREE_BAKE) inspect out/torus-obvhs.prt | grep -q '"backend": "obvhs"' || \
		{ echo "no-embree: out/torus-obvhs.prt was not baked with obvhs"; exit 1; }
	@echo "no-embree: built and baked without Embree (ldd: no libembree)"

embree4: deps
	scripts/check-embree4.sh

.PHONY: no-embree-full
no-embree-full: deps
	$(CARGO) test --release -p prt-baker --no-default-features --target-dir $(NO_EMBREE)

reference: build
	scripts/reference/run.sh

# Real assets out: exported .glb files pass the Khronos glTF-Validator with zero errors (npm
# package installed into target/node), and scripts/python/prt.py reads every .prt variant as
# the npz export has it (NumPy in a venv under target/).
interop: build
	scripts/gltf/validate.sh
	scripts/python/run-tests.sh

# The web runtime (runtime/three/prt.js) in Debian's chromium (headless, SwiftShader): its
# renders of a grey and an RGB vertex bake and a texel bake match the as-exported .glb, at the
# rig and with the light turned in JavaScript; the GLSL ES and WGSL snippets of docs/reference/gltf.md
# compile (glslangValidator; naga in prt-view's tests). About a minute.
browser: build
	scripts/browser/run.sh

# The web round trip's last step: serve the repository and print the three.js example page's
# address for GLB (a prt-bake export --glb … --lights RIG file); Ctrl-C stops it.
GLB ?=
PORT ?= 8000
web: deps
	scripts/browser/serve.sh "$(GLB)" "$(PORT)"

# A single-node Slurm cluster (slurmctld, slurmd, munged) started and stopped by the test:
# scripts/slurm/submit.sh bakes in 4 shards, the merge must equal the single-machine bake.
slurm: build
	scripts/slurm/test-cluster.sh $(BAKE)

# Interreflection against an independent path tracer: Mitsuba 3 (PyPI, in a venv under
# target/) traces diffuse paths at the Cornell room's box bases and in a room of overlapping
# boards; vertex and texel bakes, 1-4 bounces, RGB, must agree within its standard error.
mitsuba: build
	scripts/mitsuba/run.sh

# A Blender-made glTF with per-object lightmap UVs (Suzanne, a cube, a floor; Smart UV Project)
# baked per texel: no texel shared between objects, AO within Cycles' noise of Blender's own
# AO bake. Blender 4.5 LTS comes from PyPI (bpy, a 373 MB wheel) into target/blender/venv;
# about 30 s once installed (docs/guides/lightmaps.md, "Against Blender Cycles").
blender: build
	scripts/blender/run.sh

# The Blender add-on: packed into a zip, installed into a throw-away Blender user
# folder, a Suzanne, cube and floor scene baked through bpy.ops.prt.bake and relit at a rig and
# turned 90°, against prt-bake's own export of Blender's glTF of the scene (per object: mean
# within 3 %, per-vertex correlation >= 0.98); errors, cancel, the preview material; the
# production courtyard against the CLI per vertex and per lightmap texel (>= 99 % within 2 %,
# failing with cut-outs, normal maps, textures or instances switched off); a collection
# instance and a 1,000-instance geometry-nodes scatter casting shadows in memory that grows
# with meshes. Uses make blender's bpy (docs/guides/blender.md).
.PHONY: blender-addon
blender-addon: blender
	runtime/blender/test.sh

# The production-style courtyard: Blender rebuilds scenes/production/courtyard.glb
# byte for byte and bakes Cycles' AO of the ground and the normal-mapped wall; prt-bake's texel
# AO is within Cycles' noise, fails with the cut-outs or the normal map stripped, and the ground's
# vertex bake is bit for bit equal with the crates instanced or flat. Uses make blender's bpy
# (docs/guides/production-assets.md, "The production courtyard").
.PHONY: blender-production
blender-production: blender
	scripts/blender/production.sh

# The walking character (scenes/cornell/walker.glb) rebuilt by scripts/blender/make_walker.py
# must equal the committed file byte for byte (about 3 s after make blender; docs/guides/characters.md).
.PHONY: blender-walker
blender-walker: blender
	scripts/blender/walker.sh

test: lint unit no-embree embree4 reference interop slurm browser mitsuba blender
# (a line of its own, so that other additions to make test merge without conflict)
test: blender-addon
test: blender-production
test: blender-walker
test: mitsuba-subsurface
test: mitsuba-probes
test: docs-check
test: bevy

# The Bevy plugin (runtime/bevy, its own workspace and Cargo.lock, built into target/bevy so
# that make lint, make unit and make demo never compile Bevy): its unit tests, then the
# day_night example renders the torus's vertex bake and the Cornell room's texel bake headless
# on lavapipe, at a rig and turned 90°, against the exports' own colours (≥ 99 % of lit pixels
# within 2 codes), and times PRT against Bevy's own Lightmap (docs/guides/bevy.md).
# make bevy-demo-data bakes the Cornell room the interactive example opens.
.PHONY: bevy bevy-demo-data
bevy: build
	scripts/bevy/test.sh

bevy-demo-data: demo-build
	scripts/bevy/demo-data.sh

# The documentation: every `sh` block of docs/guides/*.md and README.md runs on the repository's
# scenes from a scratch folder (about a minute), links and anchors resolve, no file in docs/ is
# over 600 lines, nothing cites a stop or an issue number (scripts/docs/check-docs.py).
# docs/reference/cli.md is checked against prt-bake's help by make unit
# (baker/tests/cli_reference.rs); make cli-reference rewrites it after an option changes.
.PHONY: docs-check cli-reference
docs-check: build
	python3 scripts/docs/check-docs.py

cli-reference: deps
	PRT_BLESS=1 $(CARGO) test --release -p prt-baker --test cli_reference

bench: deps
	$(CARGO) bench -p prt-baker --bench bake
	$(CARGO) bench -p prt-baker --bench lightmap

# The texel bake's scaling matrix: its tables, then the per-texel figures that
# docs/guides/clusters.md's 16-node plan multiplies out. SCALE_* variables choose the cells.
bench-large: build
	scripts/bench-large.sh --scale

# 400,000 mutants per parser from a new seed (make test runs 20,000 from each of its fixed
# seeds): a few minutes. FUZZ_SEED=0x… replays a run; FUZZ_CASES=N sets its length.
FUZZ_SEED ?= random
FUZZ_CASES ?= 400000
fuzz: deps
	PRT_FUZZ_SEED=$(FUZZ_SEED) PRT_FUZZ_CASES=$(FUZZ_CASES) $(CARGO) test --release -p prt-baker --test fuzz -- --nocapture

# The Cornell box's 512² interreflected lightmap (RGB transfer, order 4): per-pixel PRT.
out/cornell-lightmap-512.prt: build
	@mkdir -p out
	$(BAKE) bake scenes/cornell/cornell.scene -o out/cornell-lightmap-512.prt --lightmap 512 \
		--mode interreflected --samples 64 --seed 1

# A ball of radius 0.2 as an occluder (one sphere): four copies move over the Cornell lightmap
# in bench-view's second table (docs/guides/occluders.md).
out/ball.occ: build scripts/bench/ball_obj.py
	@mkdir -p out
	python3 scripts/bench/ball_obj.py 0.2 > out/ball.obj
	$(BAKE) bake out/ball.obj --occluder -o out/ball.occ

# Each bench runs twice, the first time untimed into a log: on lavapipe, shader code that Mesa
# compiles per frame (keyed on per-frame values, docs/explanation/performance.md) is then in the bench's own
# on-disk shader cache, so the timed run measures rendering, not compiling, and repeats.
BENCH_VIEW_CACHE := target/bench-view-shader-cache
bench-view: out/torus.prt out/cornell-lightmap-512.prt out/ball.occ
	@mkdir -p $(BENCH_VIEW_CACHE)
	MESA_SHADER_CACHE_DIR=$(BENCH_VIEW_CACHE) $(VIEW) $(SCENE) out/torus.prt --bench > target/bench-view-priming.log
	MESA_SHADER_CACHE_DIR=$(BENCH_VIEW_CACHE) $(VIEW) $(SCENE) out/torus.prt --bench
	MESA_SHADER_CACHE_DIR=$(BENCH_VIEW_CACHE) $(VIEW) scenes/cornell/cornell.scene out/cornell-lightmap-512.prt --bench --bench-occluder out/ball.occ >> target/bench-view-priming.log
	MESA_SHADER_CACHE_DIR=$(BENCH_VIEW_CACHE) $(VIEW) scenes/cornell/cornell.scene out/cornell-lightmap-512.prt --bench --bench-occluder out/ball.occ

# Regenerates the committed demo scenes (a test checks they match the generator).
scenes:
	$(CARGO) run --release -p prt-scenes

# Subsurface transfer (docs/guides/subsurface.md) against Mitsuba 3's volumetric path tracer: fresh
# references for a box, a sphere and a thin slab lit from below (ior 1.0 and 1.3) in the venv
# of `make mitsuba`, then tests/subsurface.rs against them (part of make test, about 30 s).
mitsuba-subsurface: build
	scripts/mitsuba/subsurface.sh

# Transfer probes (docs/guides/probes.md) against Mitsuba 3: four probes in the Cornell room under a
# white sky, order-3 band-limited irradiance at ±x, ±y, ±z, 1 and 3 bounces, against diffuse
# paths traced on Mitsuba's rays in the venv of `make mitsuba` (part of make test, about 15 s).
mitsuba-probes: build
	scripts/mitsuba/probes.sh
