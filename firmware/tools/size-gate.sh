#!/bin/sh
# Prints the flash and static RAM use of an AVR ELF and fails when one exceeds its gate.
#   size-gate.sh AVR_SIZE ELF NAME FLASH_MAX RAM_MAX
# flash = .text + .data (the initial values of .data are stored in flash);
# static RAM = .data + .bss + .noinit (what is left of the 2 KB is heap and stack).
set -eu
avr_size=$1 elf=$2 name=$3 flash_max=$4 ram_max=$5

sizes=$("$avr_size" -A "$elf" | awk '
    $1 == ".text" { t = $2 } $1 == ".data" { d = $2 } $1 == ".bss" { b = $2 }
    $1 == ".noinit" { n = $2 }
    END { printf "%d %d\n", t + d, d + b + n }')
flash=${sizes% *}
ram=${sizes#* }

verdict=ok
status=0
if [ "$flash" -gt "$flash_max" ] || [ "$ram" -gt "$ram_max" ]; then
    verdict="OVER THE GATE"
    status=1
fi
awk -v n="$name" -v f="$flash" -v fm="$flash_max" -v r="$ram" -v rm="$ram_max" -v v="$verdict" \
    'BEGIN { printf "%-16s flash %6d / %5d B (%5.1f %%)   static RAM %5d / %4d B (%5.1f %%)   %s\n",
             n, f, fm, 100 * f / fm, r, rm, 100 * r / rm, v }'
exit $status
