# KiCad boards (pcb/): included by the top-level Makefile.
#   make pcb-tools   KiCad 9 (kicad-cli + stock libraries) from bookworm-backports when missing
#   make pcb-gen     regenerate both projects from pcb/tools (fingertip: from fingertip.toml)
#   make pcb-check   ERC (0 errors) + DRC with schematic parity (0 errors) for both boards
#   make pcb         pcb-check, then Gerbers, drill + map, BOM CSV, PDF schematic, STEP
#                    into build/pcb/<board>/

PCB_BOARDS := fingertip readout hand
PCB_OUT := build/pcb
SYS_PY := /usr/bin/python3

.PHONY: pcb pcb-tools pcb-gen pcb-check

pcb-tools:
	@pcb/tools/ensure-kicad.sh

pcb-gen: pcb-tools
	$(SYS_PY) pcb/tools/gen_fingertip.py
	$(SYS_PY) pcb/tools/gen_readout.py
	$(SYS_PY) pcb/tools/gen_hand.py

pcb-check: pcb-tools
	@set -e; for b in $(PCB_BOARDS); do \
	  mkdir -p $(PCB_OUT)/$$b; \
	  echo "pcb: $$b: ERC"; \
	  kicad-cli sch erc --format json --severity-error --exit-code-violations \
	    -o $(PCB_OUT)/$$b/erc.json pcb/$$b/$$b.kicad_sch >/dev/null || \
	    { echo "pcb: $$b: ERC errors, see $(PCB_OUT)/$$b/erc.json" >&2; exit 1; }; \
	  echo "pcb: $$b: DRC with schematic parity"; \
	  kicad-cli pcb drc --format json --schematic-parity --severity-error \
	    --exit-code-violations -o $(PCB_OUT)/$$b/drc.json pcb/$$b/$$b.kicad_pcb >/dev/null || \
	    { echo "pcb: $$b: DRC errors, see $(PCB_OUT)/$$b/drc.json" >&2; exit 1; }; \
	done; echo "pcb: ERC and DRC clean"

pcb: pcb-check
	@set -e; for b in $(PCB_BOARDS); do \
	  o=$(PCB_OUT)/$$b; mkdir -p $$o/gerbers; \
	  echo "pcb: $$b: Gerbers"; \
	  kicad-cli pcb export gerbers --no-protel-ext -o $$o/gerbers/ \
	    --layers F.Cu,B.Cu,F.Paste,B.Paste,F.SilkS,B.SilkS,F.Mask,B.Mask,Edge.Cuts \
	    pcb/$$b/$$b.kicad_pcb >/dev/null; \
	  echo "pcb: $$b: drill files + map"; \
	  kicad-cli pcb export drill --format excellon --excellon-separate-th \
	    --generate-map --map-format pdf -o $$o/gerbers/ pcb/$$b/$$b.kicad_pcb >/dev/null; \
	  echo "pcb: $$b: BOM"; \
	  kicad-cli sch export bom -o $$o/$$b-bom.csv \
	    --fields 'Reference,Value,Footprint,Manufacturer,MPN,$${QUANTITY}' \
	    --labels 'Reference,Value,Footprint,Manufacturer,MPN,Qty' \
	    --group-by 'Value,Footprint,MPN' pcb/$$b/$$b.kicad_sch >/dev/null; \
	  echo "pcb: $$b: PDF schematic"; \
	  kicad-cli sch export pdf -o $$o/$$b-schematic.pdf pcb/$$b/$$b.kicad_sch >/dev/null; \
	  echo "pcb: $$b: STEP"; \
	  kicad-cli pcb export step --drill-origin --subst-models --force \
	    -o $$o/$$b.step pcb/$$b/$$b.kicad_pcb >/dev/null; \
	done; echo "pcb: outputs in $(PCB_OUT)/"
