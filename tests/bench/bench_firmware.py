"""The real firmware in simavr: SCK timing, read cost and frame rate from the cycle counter.

The register-access firmware is measured side by side with a build that reads the chips
with digitalRead/digitalWrite as common Arduino HX711 libraries do (HX711MULTI's shared-SCK
loop), in the same harness, so the ratio does not depend on this machine's speed: simavr
counts AVR cycles, not host seconds.
"""
from __future__ import annotations

import subprocess
import time

from fingertip.sim.device.simavr import FirmwareSim, firmware_elf, open_fingertip

SIM_SECONDS = 20.0


def _size(build) -> tuple[int, int]:
    out = subprocess.run(["avr-size", "-A", str(firmware_elf(build))], check=True,
                         capture_output=True, text=True).stdout
    sec = {line.split()[0]: int(line.split()[1]) for line in out.splitlines()
           if line.startswith(".")}
    flash = sec.get(".text", 0) + sec.get(".data", 0)
    ram = sec.get(".data", 0) + sec.get(".bss", 0) + sec.get(".noinit", 0)
    return flash, ram


def _measure(build, channels: int) -> dict[str, float]:
    with FirmwareSim(channels, firmware_elf(build)) as sim:
        with open_fingertip(sim, queue_size=100_000) as ft:
            sim.stats_reset()  # boot holds SCK high on purpose: measure streaming only
            ft.start()
            t0 = sim.time_us()
            sim.until(t0 + SIM_SECONDS * 1e6, timeout=600)
            time.sleep(0.5)
            frames = ft.drain()
            st = sim.stats()
            lost = ft.stats.frames_lost
    span = (frames[-1].device_time_us - frames[0].device_time_us) / 1e6
    return {
        "sck_high_max_us": st["sck_high_us"]["max"],
        "read_us": st["read_us"]["mean"],
        "read_max_us": st["read_us"]["max"],
        "read_cpu_share": st["read_cpu_share"],
        "frames_per_s": (len(frames) - 1) / span,
        "frames_lost": lost,
        "violations_in_read": st["violations_60us"]["in_read"],
        "sim_speed": st["speed"]["ratio"],
    }


def run() -> dict[str, float]:
    fast4 = _measure(4, 4)
    fast16 = _measure(16, 16)
    slow4 = _measure("digitalread", 4)
    flash, ram = _size(4)
    flash16, ram16 = _size(16)
    return {
        "fw_sck_high_max_us": round(fast4["sck_high_max_us"], 4),
        "fw_read_us": round(fast4["read_us"], 2),
        "fw_read_max_us": round(fast4["read_max_us"], 2),
        "fw_read_cpu_share": round(fast4["read_cpu_share"], 5),
        "fw_frames_per_s_4ch": round(fast4["frames_per_s"], 3),
        "fw_frames_per_s_16ch": round(fast16["frames_per_s"], 3),
        "fw_read_us_16ch": round(fast16["read_us"], 2),
        "fw_sck_high_max_us_16ch": round(fast16["sck_high_max_us"], 4),
        "fw_frames_lost": fast4["frames_lost"] + fast16["frames_lost"],
        "fw_flash_bytes": flash,
        "fw_ram_bytes": ram,
        "fw_flash_bytes_16ch": flash16,
        "fw_ram_bytes_16ch": ram16,
        "fw_digitalread_sck_high_max_us": round(slow4["sck_high_max_us"], 4),
        "fw_digitalread_read_us": round(slow4["read_us"], 2),
        "fw_digitalread_read_cpu_share": round(slow4["read_cpu_share"], 5),
        "fw_digitalread_frames_per_s_4ch": round(slow4["frames_per_s"], 3),
        "fw_read_speedup_vs_digitalread": round(slow4["read_us"] / fast4["read_us"], 2),
        "sim_speed_4ch_x_realtime": round(fast4["sim_speed"], 2),
    }


DESCRIPTION = {
    "fw_sck_high_max_us": ("longest SCK-high pulse while streaming, 4 channels (simavr cycles)",
                           ("<", 2.0)),
    "fw_read_us": ("one full parallel read of 4 HX711s, mean (25 pulses)", ("<", 150.0)),
    "fw_read_max_us": ("same, longest", ("<", 150.0)),
    "fw_read_cpu_share": ("share of the Uno's CPU spent reading the chips, 4 channels at 80 SPS",
                          None),
    "fw_frames_per_s_4ch": ("sample frames per simulated second, 4 channels at 80 SPS",
                            (">=", 79.99)),
    "fw_frames_per_s_16ch": ("sample frames per simulated second, 16 channels at 80 SPS",
                             (">=", 79.99)),
    "fw_read_us_16ch": ("one full parallel read of 16 HX711s, mean", None),
    "fw_sck_high_max_us_16ch": ("longest SCK-high pulse, 16 channels", ("<", 2.0)),
    "fw_frames_lost": ("frames lost (sequence gaps) over both runs", ("<=", 0)),
    "fw_flash_bytes": ("flash of the 4-channel firmware (.text + .data)", ("<=", 12288)),
    "fw_ram_bytes": ("static RAM of the 4-channel firmware (.data + .bss + .noinit)",
                     ("<=", 1024)),
    "fw_flash_bytes_16ch": ("flash of the 16-channel firmware", ("<=", 32256)),
    "fw_ram_bytes_16ch": ("static RAM of the 16-channel firmware", ("<=", 2048)),
    "fw_digitalread_sck_high_max_us": ("baseline (digitalRead, HX711MULTI style): longest "
                                       "SCK high", None),
    "fw_digitalread_read_us": ("baseline: one read of 4 chips, mean", None),
    "fw_digitalread_read_cpu_share": ("baseline: CPU share spent reading", None),
    "fw_digitalread_frames_per_s_4ch": ("baseline: frames per simulated second", None),
    "fw_read_speedup_vs_digitalread": ("baseline read time / register read time, same harness",
                                       None),
    "sim_speed_4ch_x_realtime": ("simavr speed: simulated seconds per second of host CPU",
                                 None),
}
