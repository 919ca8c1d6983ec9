#!/usr/bin/env python3
"""Applicator files the design was never tuned to: the memo's, with the rotor's inertia
×0.5–2, the beam's stiffness ×0.6–1.8, the tip ×0.6–1.6, the stiction ×0.5–2, the amplifier's
pole 90–300 Hz, the contact's loss 0.2–0.5 and a gauge of 7, 14 or 28 g/V (noise 1 % of it).

    python3 scripts/random-applicators.py SEED COUNT OUT_DIR   # writes OUT_DIR/r0.toml, ...
"""
import random
import re
import sys
from pathlib import Path

seed, count, out = int(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
memo = (Path(__file__).parent.parent / "applicators" / "memo.toml").read_text()
rng = random.Random(seed)
out.mkdir(parents=True, exist_ok=True)


def value(key):
    return float(re.search(rf"^{key} = (.*)$", memo, re.M).group(1))


def put(text, key, v):
    return re.sub(rf"^{key} = .*$", f"{key} = {v!r}", text, flags=re.M)


for i in range(count):
    t = memo
    t = put(t, "motor_inertia_kg_m2", value("motor_inertia_kg_m2") * rng.uniform(0.5, 2))
    t = put(t, "beam_stiffness_n_per_m", value("beam_stiffness_n_per_m") * rng.uniform(0.6, 1.8))
    t = put(t, "tip_mass_kg", value("tip_mass_kg") * rng.uniform(0.6, 1.6))
    t = put(t, "amplifier_pole_hz", rng.uniform(90, 300))
    t = put(t, "static_friction_nm", value("static_friction_nm") * rng.uniform(0.5, 2))
    t = put(t, "contact_loss_factor", rng.uniform(0.2, 0.5))
    gauge = rng.choice([7.0, 14.0, 28.0])
    t = put(t, "gauge_g_per_v", gauge)
    t = put(t, "gauge_noise_g", 0.01 * gauge)
    (out / f"r{i}.toml").write_text(t)
