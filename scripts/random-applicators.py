#!/usr/bin/env python3
"""Applicator files the design was never tuned to, as a user might build one: the memo's with
the drive's gain moved (torque constant ×0.6–1.5, amplifier 0.12–0.28 A/V, arm 6–12 cm: 0.28–3.3
times the firmware's drive scale), the amplifier's pole 70–400 Hz, the rotor's inertia
×0.4–2.5, the viscous friction ×0.5–3, the stiction ×0.3–2.5, the beam's stiffness ×0.5–2 and
its damping ratio 0.005–0.05, the tip ×0.5–1.8, the indentation ×0.7–1.4, the contact's loss
0.15–0.6 and a gauge of 5–30 g/V with 0.5–2 % of its scale as noise. Each file's first line
says what it drew.

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


SCALED = {  # field: (low, high) factor of the memo's
    "torque_constant_nm_per_a": (0.6, 1.5),
    "motor_inertia_kg_m2": (0.4, 2.5),
    "viscous_nm_s_per_rad": (0.5, 3.0),
    "static_friction_nm": (0.3, 2.5),
    "beam_stiffness_n_per_m": (0.5, 2.0),
    "tip_mass_kg": (0.5, 1.8),
    "indentation_mm_per_100pct": (0.7, 1.4),
}
DRAWN = {  # field: (low, high) value
    "amplifier_a_per_v": (0.12, 0.28),
    "amplifier_pole_hz": (70.0, 400.0),
    "arm_m": (0.06, 0.12),
    "beam_damping_ratio": (0.005, 0.05),
    "contact_loss_factor": (0.15, 0.6),
    "gauge_g_per_v": (5.0, 30.0),
}

for i in range(count):
    t, drawn = memo, {}
    for key, (lo, hi) in SCALED.items():
        drawn[key] = rng.uniform(lo, hi)
        t = put(t, key, value(key) * drawn[key])
    for key, (lo, hi) in DRAWN.items():
        drawn[key] = rng.uniform(lo, hi)
        t = put(t, key, drawn[key])
    t = put(t, "gauge_noise_g", drawn["gauge_g_per_v"] * rng.uniform(0.005, 0.02))
    # The drive at the probe per drive volt against the memo's (the firmware's scale).
    drive = (
        drawn["torque_constant_nm_per_a"]
        * drawn["amplifier_a_per_v"]
        / value("amplifier_a_per_v")
        * value("arm_m")
        / drawn["arm_m"]
    )
    head = f"# drawn by random-applicators.py {seed}: the drive {drive:.2f}× the memo's, " + ", ".join(
        f"{k} {v:.3g}" for k, v in drawn.items()
    )
    (out / f"r{i}.toml").write_text(head + "\n" + t)
