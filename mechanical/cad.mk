# Parametric CAD (mechanical/fingertip_cad), included by the top-level Makefile.
#   make cad        build every part from fingertip.toml; STL + STEP per part, the assemblies
#                   as STEP, PNG renders and manifest.json in build/cad/
#   make cad-docs   refresh the renders in docs/img/ (cad_fingertip.png, cad_mold.png)
# CAD_ARGS passes options, e.g. make cad CAD_ARGS="--set geometry.outer_width_mm=22".

CAD_OUT ?= build/cad
CAD_ARGS ?=

.PHONY: cad cad-docs

cad: venv-fab
	$(VPY) -m fingertip_cad --out $(CAD_OUT) $(CAD_ARGS)

cad-docs: cad
	cp $(CAD_OUT)/cad_fingertip.png $(CAD_OUT)/cad_mold.png docs/img/
