//! The designed force controller on the memo's rig: identified from the excitation
//! at six preloads, designed on the host, run by the core's loop on the simulator, against A1
//! on the same rig. Bounds are the figures measured when it was built with a margin
//! (`cargo run --release -p sim-host --example design_controller` prints them); the issue's
//! targets that are not met yet are not asserted (the note says which).

use sim_host::design::{self, Design};
use sim_host::metrics;
use sim_host::rig::RigConfig;
use sim_host::rig::TickRecord;
use sim_host::scenario::{run_named, ScenarioOptions};
use tactile_core::telemetry::FaultFlags;

fn rig() -> RigConfig {
    RigConfig {
        scan_array: false,
        ..Default::default()
    }
}

/// The ticks of the named protocol on `cfg`.
/// The closed loop's magnitude, dB, for `amplitude_g` about `offset_g` at `hz`, printed after
/// `label` and asserted within `(lo, hi)`.
fn magnitude_db(
    cfg: &RigConfig,
    label: &str,
    (offset_g, amplitude_g, hz): (f64, f64, f64),
    (lo, hi): (f64, f64),
) -> f64 {
    let g = metrics::closed_loop_gain(cfg.clone(), offset_g, amplitude_g, hz).unwrap();
    let db = 20.0 * g.log10();
    eprintln!("{label}{amplitude_g} g about {offset_g} g, {hz} Hz: {db:+.2} dB");
    assert!(
        (lo..=hi).contains(&db),
        "{label}{offset_g} g, {hz} Hz: {db:+.2} dB"
    );
    db
}

/// The bounds for a sine about `offset_g`: `LIGHT_LOAD_DB` under 50 g, the target's ±1 dB
/// above.
fn flat_db(offset_g: f64) -> (f64, f64) {
    if offset_g < 50.0 {
        LIGHT_LOAD_DB
    } else {
        (-1.0, 1.0)
    }
}

fn ticks(protocol: &str, cfg: &RigConfig) -> Vec<TickRecord> {
    run_named(protocol, &ScenarioOptions::default(), cfg.clone(), |_| {})
        .unwrap()
        .ticks
}

/// The rigs of `applicators/`: the memo's, a heavy motor on a soft beam, a light motor with
/// twice the stiction on a stiffer beam, the memo's with a slow amplifier and 1.5× the
/// stiction (file name, the simulator's rig with it).
fn rigs() -> [(&'static str, RigConfig); 4] {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../applicators");
    [
        "memo.toml",
        "heavy-motor-soft-beam.toml",
        "light-motor-stiff-beam.toml",
        "slow-amplifier.toml",
    ]
    .map(|file| {
        let mut cfg = rig();
        cfg.set_applicator(sim_host::error::read_applicator(&root.join(file)).unwrap());
        (file, cfg)
    })
}

fn designed() -> (RigConfig, Design) {
    let base = rig();
    let d = design::design_for_rig(&base).expect("design").design;
    let mut cfg = base;
    cfg.firmware.designed = Some(d.config);
    (cfg, d)
}

#[test]
fn the_designed_loop_holds_with_twice_its_feedback_gains() {
    // Checked on the simulator's plant with its stiction, which the design never saw: with kp
    // and ki doubled the loop still holds every load from 3 to 120 g without ringing (RMS of
    // true − command over the last half second of a 1.5 s hold, against the gauge's 0.14 g of
    // noise).
    let (cfg, d) = designed();
    let hold = |gain: f32, load_g: f32| {
        let mut c = cfg.clone();
        let mut t = d.config;
        t.kp *= gain;
        t.ki_per_s *= gain;
        c.firmware.designed = Some(t);
        let mut rig = sim_host::rig::Rig::new(c).unwrap();
        let ticks: Vec<_> = (0..1500).map(|_| rig.tick(load_g, |_, _| {})).collect();
        metrics::rms(
            &ticks[1000..],
            |r| f64::from(r.true_force_g),
            |_| f64::from(load_g),
        )
    };
    for load_g in [3.0, 10.0, 30.0, 60.0, 100.0, 120.0] {
        let (one, two) = (hold(1.0, load_g), hold(2.0, load_g));
        eprintln!("{load_g} g: RMS error {one:.3} g, ×2 {two:.3} g");
        assert!(one < 0.2 && two < 0.5, "{load_g} g: ×1 {one} g, ×2 {two} g");
    }
}

/// The least margins of table `c` over `loads_g` on the friction-free linearization of the
/// applicator `p` (the memo finger's spring, the drive's hold of one tick): a plant the design
/// never saw, without the stiction that damps the identified models.
fn friction_free_margins(
    p: &sim_host::applicator::ApplicatorParams,
    c: &tactile_core::designed::DesignedConfig,
    loads_g: &[f64],
) -> (f64, f64) {
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    loads_g
        .iter()
        .fold((f64::INFINITY, 180.0f64), |(gm, pm), &load| {
            let feedback = design::table_feedback(c, load as f32);
            let l: Vec<_> = design::loop_grid_hz()
                .into_iter()
                .map(|hz| feedback(hz) * sim_host::analysis::held_response(p, &law, load, hz))
                .collect();
            let m = design::margins(&l);
            (gm.min(m.gain), pm.min(m.phase_deg))
        })
}

#[test]
fn the_designed_feedback_keeps_its_margins_on_the_friction_free_plant() {
    // The margins (gain ≥ 2, phase ≥ 45° from 2 to 120 g) on each rig's friction-free
    // linearization, and on the memo rig's with each mechanical parameter 20 % off. Designed on
    // the identified damping alone (no floor), the memo rig's feedback had a gain margin of
    // 0.6–1.0 here: the stiction was what kept it from ringing.
    let loads = [2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 120.0];
    for (file, cfg) in rigs() {
        let c = design::design_for_rig(&cfg).expect("design").design.config;
        let (gm, pm) = friction_free_margins(&cfg.applicator, &c, &loads);
        eprintln!("{file}: gain margin {gm:.2}, phase margin {pm:.0}°");
        assert!(gm >= 2.0 && pm >= 45.0, "{file}: {gm:.2}, {pm:.0}°");
        if file != "memo.toml" {
            continue;
        }
        let p = cfg.applicator;
        for (name, field) in sim_host::analysis::MECHANICAL_PARAMETERS {
            for f in [0.8, 1.2] {
                let mut q = p;
                *field(&mut q) *= f;
                let (gm, pm) = friction_free_margins(&q, &c, &loads);
                eprintln!("  {name} ×{f}: gain margin {gm:.2}, phase margin {pm:.0}°");
                assert!(gm >= 2.0 && pm >= 45.0, "{name} ×{f}: {gm:.2}, {pm:.0}°");
            }
        }
    }
}

/// The closed loop's bounds for a 2 g sine about 10 g, dB. The issue's ±1 dB is not met there
/// above the light load's inertia–finger mode (docs/design.md, "Not yet"): the sine needs less
/// drive than the stiction, and the figure follows the friction compensation's size, which
/// the loop learns from sines slower than the mode (`designed::FrictionAdapt`; the heavy rig's
/// 25 Hz −8.3 → −0.5 dB) but not above it, where the memo rig's 40 Hz is −1.74 dB short, the
/// sensitive gauge's rig's −1.76 (−2.9 and −3.3 before the friction compensation passed the
/// amplifier's inverse and the feedback compared the reading the reference predicts; −2.4
/// before the feed-forward took the contact's stiffening in, which brought a 5 g sine there
/// from +2…+3.4 dB to within ±1 dB: `LARGER_SINE_DB`). What the tests hold is that nothing
/// over-drives the mode (+17 dB at 30 Hz on an unseen rig before the identification simulated
/// the friction) and that the shortfall stays under 2.5 dB.
const LIGHT_LOAD_DB: (f64, f64) = (-2.5, 1.25);

#[test]
fn the_friction_compensation_learns_a_stiction_it_was_not_told() {
    // Designed on the memo's rig (its holds read 1.01 g of stiction), run on the same rig with
    // its motor sticking 1.2 and 0.85 times as hard (1.33 and 0.94 g): a 2 g sine about 10 g,
    // 10–30 Hz (under the 10 g mode, 35 Hz, where it learns). Compensating a fixed stiction
    // 20 % off was several dB off: 1.2 × the file's took the memo rig's 30 Hz from −2.2 to
    // +3.7 dB.
    let (designed, _) = designed();
    for factor in [1.2, 0.85] {
        let mut cfg = designed.clone();
        let mut p = sim_host::applicator::ApplicatorParams::MEMO;
        p.static_friction_nm *= factor;
        cfg.set_applicator(p);
        for hz in [10.0, 20.0, 25.0, 30.0] {
            let label = format!("stiction ×{factor}, ");
            magnitude_db(&cfg, &label, (10.0, 2.0, hz), (-1.5, 1.5));
        }
    }
}

/// The closed loop's bounds for a 5 g sine about 10 g, dB.
const LARGER_SINE_DB: (f64, f64) = (-1.25, 1.25);

#[test]
fn a_larger_sine_at_a_light_load_takes_the_contacts_stiffening_in() {
    // 5 g about 10 g on the memo's rig, to 40 Hz (above its 10 g mode, 35 Hz): the finger
    // stiffens by a third over the swing, and the force's own rate takes drive there
    // (dc₂/dF·F'², the designed controller's feed-forward). Without that term the sine rang +2.5 dB at
    // 40 Hz (measured with the term taken out); with it −0.86…+0.57 dB at 5–40 Hz.
    let (designed, _) = designed();
    for hz in [5.0, 20.0, 30.0, 40.0] {
        magnitude_db(&designed, "5 g, ", (10.0, 5.0, hz), LARGER_SINE_DB);
    }
}

#[test]
fn more_stiction_does_not_make_the_feed_forward_ring_a_light_load() {
    // The memo's rig with 1.5 and 2 times its stiction, seeds 1 and 2: a 2 g sine about 10 g,
    // where the sine needs less drive than the stiction near the inertia–finger mode. When the
    // identification read the sticking motor as the mode's damping, the feed-forward over-drove
    // the mode on such rigs (an unseen rig with twice the stiction: +17 dB at 30 Hz; here, at
    // 5fddb39, 1.5×: +1.97 / +2.96 dB and 2×: +7.90 / +9.55 dB at 30 Hz, seeds 1 / 2, in
    // `design_controller`). With the friction simulated in the identification and its size
    // learnt under the 10 g mode (35 Hz): −0.77…+1.27 dB at 20–30 Hz (+1.74 dB at most before
    // it learnt); above the mode, at 40 Hz, −0.38…−1.31 dB (−3.5 to −4.8 dB before the
    // compensation passed the amplifier's inverse).
    for factor in [1.5, 2.0] {
        for seed in [1, 2] {
            let mut cfg = RigConfig { seed, ..rig() };
            let mut p = sim_host::applicator::ApplicatorParams::MEMO;
            p.static_friction_nm *= factor;
            cfg.set_applicator(p);
            cfg.firmware.designed =
                Some(design::design_for_rig(&cfg).expect("design").design.config);
            for hz in [20.0, 25.0, 30.0, 40.0] {
                let label = format!("stiction ×{factor}, seed {seed}, ");
                magnitude_db(&cfg, &label, (10.0, 2.0, hz), (-1.5, 1.5));
            }
        }
    }
}

/// The feedback compares the reading with the one the reference predicts (the period's mean,
/// `READING_LAG_TICKS`, and the tip's inertia, `gauge_s2`), so where the feed-forward is right
/// it has nothing to correct. On the memo's rig with a twentieth of its stiction and no
/// compensation, a sine about 50 g with the feedback against without: within 0.15 dB at
/// 10–40 Hz (measured 0.00–0.04 dB apart). Against the reference two ticks back, as before,
/// the feedback pulled the loop to −0.57 dB at 10 Hz where the feed-forward alone was −0.01.
#[test]
fn the_feedback_leaves_a_right_feed_forward_alone() {
    let (designed, _) = designed();
    let mut with = designed.clone();
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.static_friction_nm *= 0.05;
    with.set_applicator(p);
    let mut t = designed.firmware.designed.expect("designed");
    t.friction_g = 0.0;
    t.held_friction_g = 0.0;
    with.firmware.designed = Some(t);
    let mut without = with.clone();
    without.firmware.designed = Some(tactile_core::designed::DesignedConfig {
        kp: 0.0,
        ki_per_s: 0.0,
        ..t
    });
    for hz in [10.0, 20.0, 30.0, 40.0] {
        let db = |c: &RigConfig| {
            20.0 * metrics::closed_loop_gain(c.clone(), 50.0, 10.0, hz)
                .unwrap()
                .log10()
        };
        let (a, b) = (db(&with), db(&without));
        eprintln!("{hz} Hz: with the feedback {a:+.3} dB, without {b:+.3} dB");
        assert!(
            (a - b).abs() < 0.15,
            "{hz} Hz: {a:+.3} dB against {b:+.3} dB"
        );
    }
}

#[test]
fn the_designed_loop_is_flatter_and_lands_softer_than_a1() {
    let (cfg, _) = designed();
    let a1 = rig();
    // Closed-loop magnitude, 10 g about 50 g and about 100 g: within the target's ±1 dB from
    // 0.5 to 40 Hz (measured −0.22…+0.03 dB; −0.37…+0.47 dB before the feedback compared the
    // reading the reference predicts; +1.60 dB at 40 Hz about 50 g while the
    // feed-forward's y''' was the reference's at the tick's end and its series was truncated
    // after s³, +2.51 dB when the identification also read the motor's friction as the modes'
    // damping); A1 peaks near +9 dB at 30 Hz. And a light load, 2 g about 10 g, where the drive
    // a sine needs near the inertia–finger mode is less than the stiction: within
    // `LIGHT_LOAD_DB` (measured −1.74 dB at 40 Hz, above the 10 g mode; −0.93…+0.52 dB under).
    for (offset, amplitude) in [(50.0, 10.0), (100.0, 10.0), (10.0, 2.0)] {
        for hz in [0.5, 5.0, 10.0, 20.0, 25.0, 30.0, 40.0] {
            magnitude_db(&cfg, "designed, ", (offset, amplitude, hz), flat_db(offset));
        }
    }
    let designed_30 = metrics::closed_loop_gain(cfg.clone(), 50.0, 10.0, 30.0).unwrap();
    let a1_30 = metrics::closed_loop_gain(a1.clone(), 50.0, 10.0, 30.0).unwrap();
    assert!(20.0 * a1_30.log10() > 6.0);
    assert!(20.0 * (a1_30 / designed_30).log10() > 5.0);

    // Force steps: every step after the first (from rest) into ±1 g within 30 ms (measured
    // 19–20 ms; 25 ms before a move from rest dropped what the integral pushed against it; 26 ms with a quarter of the stiction compensated, 31 ms down from 100 g to
    // 90 g before a reversal dropped what the integral carried against the friction, 53 ms
    // before the friction held at rest; A1 takes up to 69 ms); overshoot within the target's
    // 1 g (measured ≤ 0.28 g; 0.60 g with a quarter of the stiction; A1's up to 4.4 g).
    let steps = ticks("force-steps", &cfg);
    let settle = metrics::settling_after_first_s(&steps);
    eprintln!("settling after the first step: {settle:?}");
    assert!(settle.last().is_some_and(|t| *t <= 0.030), "{settle:?}");
    for (level, over) in metrics::step_overshoots_g(&steps).into_iter().skip(1) {
        assert!(over <= 1.0, "{level} g: overshoot {over} g");
    }

    // Touch-down after a rest (low-force): 8, 6, 4, 2 g overshoot by at most the target's 1 g
    // (measured 0.05–0.14 g; 0.7–2.5 g before the touch-down and its ramp), where A1
    // overshoots 6 g by about 20 g.
    let touch = |c: &RigConfig| {
        let ticks = ticks("low-force", c);
        metrics::step_overshoots_g(&ticks)
            .into_iter()
            .filter(|(level, _)| *level > 0.0)
            .collect::<Vec<_>>()
    };
    let (new, old) = (touch(&cfg), touch(&a1));
    eprintln!("touch-down overshoot, designed {new:?}, A1 {old:?}");
    assert!(new.iter().all(|(_, o)| *o <= 1.0), "{new:?}");
    assert!(old.iter().any(|(_, o)| *o > 10.0), "{old:?}");
}

/// A rest unloads the finger down the touch-down's ramp reversed, so the probe leaves it
/// slowly and the next touch-down is a short one. A heavy motor on a stiff beam (1.75× the
/// memo's inertia and beam, a 0.6× tip, 1.4× the stiction, a 28 g/V gauge), its loop following
/// the supervisor's 500 g/s down to rest, threw the probe off the finger: `low-force`'s 2 g
/// hold was 1.6 g short 0.3 s after its command (a rig of seed 2028 of
/// `scripts/random-applicators.py` like it, 0.45 mm off after 6 g, its 4 g 3.8 g short). Now
/// every hold is within a gram of its command 0.3 s after it (measured: at most 0.40 g).
/// And the rest ends when the gauge reads the finger unloaded: on a light motor with a stiff
/// beam and a heavy tip (seed 2028's r7), the motor stuck at the end of the unloading ramp
/// left the finger at 0.85 g through the rest, and the next 4 g touch-down landed 2.3 g over.
#[test]
fn a_rest_unloads_the_finger_so_the_next_touch_down_is_prompt() {
    let memo = sim_host::applicator::ApplicatorParams::MEMO;
    let heavy_motor = sim_host::applicator::ApplicatorParams {
        motor_inertia_kg_m2: memo.motor_inertia_kg_m2 * 1.75,
        beam_stiffness_n_per_m: memo.beam_stiffness_n_per_m * 1.75,
        tip_mass_kg: memo.tip_mass_kg * 0.6,
        amplifier_pole_hz: 150.0,
        static_friction_nm: memo.static_friction_nm * 1.4,
        contact_loss_factor: 0.29,
        gauge_g_per_v: 28.0,
        gauge_noise_g: 0.28,
        ..memo
    };
    let light_motor = sim_host::applicator::ApplicatorParams {
        motor_inertia_kg_m2: 2.3964592e-5,
        beam_stiffness_n_per_m: 2959.6,
        tip_mass_kg: 0.0037219,
        amplifier_pole_hz: 221.5,
        static_friction_nm: 0.0013588,
        contact_loss_factor: 0.42,
        ..heavy_motor
    };
    for p in [heavy_motor, light_motor] {
        let mut cfg = rig();
        cfg.set_applicator(p);
        cfg.firmware.designed = Some(design::design_for_rig(&cfg).expect("design").design.config);
        let low = ticks("low-force", &cfg);
        let holds = metrics::hold_quality(&low, 0.3);
        let landed = metrics::step_overshoots_g(&low);
        eprintln!("low-force, holds after 0.3 s: {holds:?}; past each level: {landed:?}");
        assert_eq!(holds.len(), 4, "{holds:?}");
        for (level_g, lost, worst_g) in holds {
            assert!(
                lost == 0.0 && worst_g < 1.0,
                "{level_g} g: {lost} {worst_g}"
            );
        }
        assert!(landed.iter().all(|(_, o)| *o <= 1.0), "{landed:?}");
    }
}

#[test]
fn the_touch_down_lands_within_a_gram_from_a_gap_on_every_rig() {
    // The target: from out of contact to 2, 5 and 10 g, overshoot ≤ 1 g. The probe at
    // rest 0.2 and 1 mm off the finger of each rig of `applicators/` (measured with
    // `cargo run --release -p sim-host --example touch_down FILE`: at most +0.42 g, on the
    // finger after 50–1130 ms, the last 0.2 s of 3 s within 0.10 g of the command. Of 2.5 s,
    // the heavy rig from 1 mm to 5 g was 0.17 g short: its motor stuck 0.19 g short where the
    // touch-down's ramp ended and the integral, slow at that rig's light loads, took 1.4 s to
    // free it). A1 on the memo rig from 0.2 mm strikes the finger with what its loop
    // accelerated the probe to.
    for (file, mut cfg) in rigs() {
        let a1 = cfg.clone();
        cfg.firmware.designed = Some(design::design_for_rig(&cfg).expect("design").design.config);
        for gap_mm in [0.2, 1.0] {
            for target_g in [2.0, 5.0, 10.0] {
                let t = metrics::touch_down(cfg.clone(), gap_mm * 1e-3, target_g, 3.0).unwrap();
                eprintln!("{file}, {gap_mm} mm → {target_g} g: {t:?}");
                assert!(
                    t.contact_s.is_some_and(|s| s < 1.5)
                        && t.overshoot_g <= 1.0
                        && (t.final_g - target_g).abs() < 0.14,
                    "{file}, {gap_mm} mm → {target_g} g: {t:?}"
                );
            }
        }
        if file == "memo.toml" {
            let t = metrics::touch_down(a1, 0.2e-3, 5.0, 1.0).unwrap();
            eprintln!("A1, {file}, 0.2 mm → 5 g: {t:?}");
            assert!(t.overshoot_g > 3.0, "{t:?}");
        }
    }
}

#[test]
fn the_procedure_works_unchanged_on_other_applicators() {
    // The four rigs of `applicators/`: the memo's, a heavy motor on a soft beam, a light motor
    // with twice the stiction on a stiffer beam, the memo's with an 80 Hz amplifier and 1.5×
    // the stiction. The holds give the static gain (1: the drive's grams are the motor's force
    // at the probe) and the stiction the file has (10, 20 or 15 g·cm on a 9 cm arm: 1.11,
    // 2.22 or 1.67 g); every force step after the first settles into ±1 g within the target's
    // 30 ms (measured: memo 19–20 ms, heavy 17–20 ms, light 18–20 ms, slow amplifier
    // 19–25 ms, at most 25 ms on seeds 2 and 3; with a flat chirp the slow amplifier's fits
    // put its pole at 29 Hz and its steps took up to 54 ms, 2.37 g over; with half the
    // stiction held at rest the light rig's 60 g step stopped 1.1 g short for 57 ms; while a
    // move from rest dropped what the integral pushed against it up to the stiction only, the
    // light rig's 20 → 30 g stopped 1.5 g short for 34 ms at seed 3), and overshoots by at
    // most the target's 1 g (measured: the heavy rig's 10 → 20 g 0.84 g, its 90 → 80 g 0.90 g
    // at seed 3; the others at most 0.42 g; the heavy rig's 10 → 20 g was 1.07 g before the
    // feed-forward's y''' came from y'').
    for ((file, mut cfg), stiction_g) in rigs().into_iter().zip([1.11, 1.11, 2.22, 1.67]) {
        let r = design::design_for_rig(&cfg).expect("design");
        let id = &r.identified;
        eprintln!(
            "{file}: static gain {:.3}, stiction {:.2} g, gauge noise {:.3} g",
            id.static_gain, id.stiction_g, id.gauge_noise_g
        );
        assert!((id.static_gain - 1.0).abs() < 0.02, "{file}: {id:?}");
        // The gauge's noise from the holds, the file's within 10 % (the light rig's gauge is
        // half as sensitive: 0.28 g).
        let noise_g = cfg.applicator.gauge_noise_g;
        assert!(
            (id.gauge_noise_g / noise_g - 1.0).abs() < 0.1,
            "{file}: {} g of noise for {noise_g}",
            id.gauge_noise_g
        );
        assert!(
            (id.stiction_g - stiction_g).abs() < 0.15 * stiction_g,
            "{file}: {} g",
            id.stiction_g
        );
        cfg.firmware.designed = Some(r.design.config);
        // The closed loop within the target's ±1 dB to 40 Hz, 10 g about 50 and 100 g (measured
        // at this seed, 5–40 Hz: memo −0.22…+0.03 dB, heavy −0.06…+0.16, light −0.51…+0.00,
        // slow amplifier −0.13…+0.10 (−0.43…+0.50, −0.37…+0.41, −0.42…+0.01, −0.36…+0.71 at
        // 0.5–40 Hz before the feedback compared the reading the reference predicts; the heavy
        // rig at seeds 2 and 3 then within +0.48 dB). While A1's
        // feedback ran through the excitation's chirp, the heavy rig's 100 g chirp left the
        // gauge's range, its model was extrapolated from 75 g and it reached +2.2 dB at 40 Hz at
        // seeds 2 and 3; before the feed-forward's y''' came from y'' and its series was fitted
        // over the band, +1.60, +4.15, −0.51 and +2.48 dB at 40 Hz).
        for offset_g in [50.0, 100.0] {
            for hz in [5.0, 20.0, 30.0, 40.0] {
                let label = format!("{file}: ");
                magnitude_db(&cfg, &label, (offset_g, 10.0, hz), (-1.0, 1.0));
            }
        }
        // Every hold of `low-force` (8, 6, 4, 2 g, each after a second's rest) on the finger
        // from 0.5 s in, and within 0.5 g of the command from 1 s in (measured: in contact
        // throughout, worst 0.04–0.22 g. Before a rest drove nothing, the heavy rig's held
        // friction and integral threw the probe 9.5 mm off at the first rest, and its 6, 4 and
        // 2 g holds never met the finger).
        let low = ticks("low-force", &cfg);
        let (landed, held) = (
            metrics::hold_quality(&low, 0.5),
            metrics::hold_quality(&low, 1.0),
        );
        eprintln!("{file}: low-force from 0.5 s {landed:?}, from 1 s {held:?}");
        assert_eq!(landed.len(), 4, "{file}: {landed:?}");
        assert!(landed.iter().all(|h| h.1 == 0.0), "{file}: {landed:?}");
        assert!(held.iter().all(|h| h.2 <= 0.5), "{file}: {held:?}");
        let steps = ticks("force-steps", &cfg);
        let settle = metrics::settling_after_first_s(&steps);
        eprintln!("{file}: settling after the first step {settle:?}");
        assert!(
            settle.last().is_some_and(|t| *t <= 0.030),
            "{file}: {settle:?}"
        );
        let over: Vec<(f32, f32)> = metrics::step_overshoots_g(&steps)
            .into_iter()
            .skip(1)
            .collect();
        assert!(over.iter().all(|o| o.1 <= 1.0), "{file}: {over:?}");
    }
}

#[test]
fn a_rig_without_friction_is_refused_with_the_reason() {
    // Without stiction nothing takes the momentum the touch-down's pulses leave (their brake is
    // half the push), and after `low-force`'s rests the probe struck the finger at 20–34 g
    // (measured before this refusal; a twentieth of the memo's stiction, 1.53 g over). The
    // design says why instead of writing a table that would.
    let mut cfg = rig();
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.static_friction_nm = 0.0;
    cfg.set_applicator(p);
    match design::design_for_rig(&cfg) {
        Err(e @ design::DesignError::TooLittleFriction { stiction_g, .. }) => {
            assert!(stiction_g < 0.02, "{e}");
            assert!(
                e.to_string().contains("a sensor of the motor's position"),
                "{e}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_rig_with_light_friction_lands_from_rest_on_the_finger() {
    // The memo's rig with a quarter and a tenth of its stiction (a better motor: 0.28 and
    // 0.11 g at the probe). At rest on the finger the touch-down's brake pulls the probe back
    // between pushes, and the reading stays at 0.16–0.30 g, under the contact force: before
    // the pulse cycle's mean counted as contact, the quarter-stiction rig's first 10 g step
    // never landed in its 0.5 s and its 20 g took 419 ms. Measured (`ONLY=1 cargo run
    // --release -p sim-host --example design_controller FILE`): the first step settles in
    // 135 / 251 ms (it includes the touch-down's ramp), every later one in 18–19 ms, every
    // low-force hold in contact.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../applicators");
    for share in [0.25, 0.1] {
        let mut cfg = rig();
        cfg.set_applicator(sim_host::error::read_applicator(&root.join("memo.toml")).unwrap());
        cfg.applicator.static_friction_nm *= share;
        cfg.firmware.designed = Some(design::design_for_rig(&cfg).expect("design").design.config);
        let steps = ticks("force-steps", &cfg);
        let first = metrics::step_settling_s(&steps).first().and_then(|s| s.1);
        let later = metrics::settling_after_first_s(&steps);
        eprintln!("{share} of the stiction: first step {first:?}, later {later:?}");
        assert!(first.is_some_and(|t| t < 0.4), "{share}: {first:?}");
        assert!(
            later.last().is_some_and(|t| *t <= 0.030),
            "{share}: {later:?}"
        );
        let low = ticks("low-force", &cfg);
        let landed = metrics::hold_quality(&low, 0.5);
        assert!(
            landed.len() == 4 && landed.iter().all(|h| h.1 == 0.0),
            "{share}: {landed:?}"
        );
    }
}

#[test]
fn the_steady_state_error_is_within_the_gauges_noise_from_2_to_120_g() {
    // The target: the steady-state error at 2–120 g within the gauge's noise (0.14 g RMS).
    // Holds of 3 s each (`low-force`'s), up from rest and back down, on each rig: the mean
    // contact force over each hold's second half less the command (measured: within 0.12 g
    // on all four rigs. While A1's feedback ran through the identification's chirp, the heavy
    // rig's 5 g hold after 20 g sat 0.26 g under, its motor stuck past the target and its
    // integral slow to free it; of 1 s holds the mean of the second half was off by up to
    // 0.18 g after the 120 → 60 g step on three rigs and 0.49 g at the heavy rig's 5 g).
    let all: Vec<(&str, Vec<(f32, f32)>)> = rigs()
        .into_iter()
        .map(|(file, mut cfg)| {
            cfg.firmware.designed =
                Some(design::design_for_rig(&cfg).expect("design").design.config);
            let errors =
                metrics::steady_errors_g(cfg, &metrics::STEADY_LEVELS_G, metrics::STEADY_HOLD_S)
                    .unwrap();
            eprintln!("{file}: {errors:?}");
            (file, errors)
        })
        .collect();
    for (file, errors) in all {
        assert!(
            errors.iter().all(|e| e.1.abs() <= 0.14),
            "{file}: {errors:?}"
        );
    }
}

#[test]
fn the_committed_controller_table_is_what_tactile_design_writes() {
    // The QEMU build carries boards/controller/table.bin; regenerate it with
    // `tactile design --table boards/controller/table.bin` when the design changes.
    let committed = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../boards/controller/table.bin"),
    )
    .unwrap();
    let (_, d) = designed();
    assert_eq!(d.config.encode().unwrap().to_vec(), committed);
    assert_eq!(
        tactile_core::designed::DesignedConfig::decode(&committed),
        Ok(d.config)
    );
}

#[test]
fn a_gauge_twice_as_sensitive_is_identified_within_its_range() {
    // The memo's rig with a gauge of 7 g/V (0.07 g of noise): the converter reads up to
    // 67.5 g, and the 75 g preload's hold alone put it at its rail, which refused the whole
    // design. The preloads within 90 % of the range are identified (10–50 g), the heavier
    // loads extrapolated, and the loop about 10 and 50 g is as flat as on the memo's gauge
    // (measured: 10 g about 50 g −0.36…+0.52 dB, 0.5–40 Hz; 2 g about 10 g, see
    // `LIGHT_LOAD_DB`).
    let mut cfg = rig();
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.gauge_g_per_v = 7.0;
    p.gauge_noise_g = 0.07;
    cfg.set_applicator(p);
    let r = design::design_for_rig(&cfg).expect("design");
    let loads: Vec<f32> = r.identified.models.iter().map(|m| m.load_g).collect();
    assert_eq!(loads, [10.0, 20.0, 35.0, 50.0], "{loads:?}");
    // Its gauge reads to 67.5 g (135 g at 14 g/V): the loop takes commands to 90 % of that,
    // 60.75 g, and a sine to 110 g has no magnitude: the benchmark says so rather than
    // printing the clipped (or, before the clamp, the stopped) rig's −38 dB.
    match metrics::closed_loop_gain(cfg.clone(), 100.0, 10.0, 10.0) {
        Err(metrics::GainError::Clamped { .. }) => {}
        other => panic!("{other:?}"),
    }
    assert!((r.identified.gauge_noise_g - 0.07).abs() < 0.01, "{r:?}");
    cfg.firmware.designed = Some(r.design.config);
    // `force-steps` to 100 g: the steps past 60.75 g hold there, flagged as clamped, and the
    // loop runs on (before the clamp, the 70 g step drove the reading out of the gauge's range
    // and the supervisor stopped the drive for the rest of the run).
    let steps = ticks("force-steps", &cfg);
    let top_g = 0.9 * 67.5;
    assert!(steps
        .iter()
        .all(|t| !t.faults.contains(FaultFlags::LATCHED)));
    let at_100 = steps.iter().find(|t| (5.4..5.5).contains(&t.t_s)).unwrap();
    assert_eq!(at_100.command_g, 100.0);
    assert!(
        at_100.faults.contains(FaultFlags::COMMAND_CLAMPED),
        "{at_100:?}"
    );
    assert!((at_100.true_force_g - top_g).abs() < 1.0, "{at_100:?}");
    let at_20 = steps.iter().find(|t| (9.4..9.5).contains(&t.t_s)).unwrap();
    assert!((at_20.true_force_g - 20.0).abs() < 1.0, "{at_20:?}");
    // The step figures judge the steps the loop takes: 10–60 g up and 60–10 g down, not the
    // clamped ones (judged against 70–100 g they read 29 g of "overshoot" and never settled).
    let settled = metrics::step_settling_s(&steps);
    let levels: Vec<f32> = settled.iter().map(|(l, _)| *l).collect();
    assert_eq!(
        levels,
        [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 60.0, 50.0, 40.0, 30.0, 20.0, 10.0]
    );
    assert!(
        settled
            .iter()
            .skip(1)
            .all(|(_, t)| t.is_some_and(|t| t < 0.03)),
        "{settled:?}"
    );
    assert!(
        metrics::step_overshoots_g(&steps)
            .iter()
            .all(|(_, o)| *o <= 1.0),
        "{:?}",
        metrics::step_overshoots_g(&steps)
    );
    for (offset_g, amplitude_g) in [(10.0, 2.0), (50.0, 10.0)] {
        for hz in [5.0, 20.0, 30.0, 40.0] {
            magnitude_db(&cfg, "", (offset_g, amplitude_g, hz), flat_db(offset_g));
        }
    }
}

#[test]
fn tactile_experiment_runs_the_designed_loop_from_a_table_and_refuses_a_damaged_one() {
    // The committed table read as `tactile experiment --controller` reads it: the force steps
    // settle as the designed loop's do when the design hands it over.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let table = root.join("boards/controller/table.bin");
    let mut cfg = rig();
    cfg.firmware.designed = Some(sim_host::error::read_controller(&table).unwrap());
    let out = crate::common::scratch("controller_experiment");
    let o = sim_host::cli::experiment(
        "force-steps",
        &ScenarioOptions::default(),
        cfg,
        &out,
        200.0,
        false,
    )
    .unwrap();
    let settle = metrics::settling_after_first_s(&o.run.ticks);
    eprintln!("force-steps under the committed table: settling after the first {settle:?}");
    assert!(settle.last().is_some_and(|t| *t <= 0.030), "{settle:?}");
    let over = metrics::step_overshoots_g(&o.run.ticks);
    assert!(over.iter().skip(1).all(|o| o.1 <= 1.0), "{over:?}");
    let record = std::fs::read_to_string(out.join("force-steps.csv")).unwrap();
    assert!(record.contains("law") && record.contains("designed"));

    // The command: the same run from the file, and a table with a flipped byte refused with
    // the firmware's reason, naming the file (exit 1), before anything runs.
    let (code, stdout, stderr) = crate::common::tactile([
        "experiment".as_ref(),
        "force-steps".as_ref(),
        "--no-plot".as_ref(),
        "--controller".as_ref(),
        table.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let mut bytes = std::fs::read(&table).unwrap();
    bytes[40] ^= 0x10;
    let damaged = crate::common::scratch("damaged_table.bin");
    std::fs::write(&damaged, bytes).unwrap();
    let readme = root.join("README.md");
    for (file, reason) in [
        (damaged.as_path(), "checksum"),
        (readme.as_path(), "no TCTL header"),
    ] {
        let (code, _, stderr) = crate::common::tactile([
            "experiment".as_ref(),
            "force-steps".as_ref(),
            "--controller".as_ref(),
            file.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        eprintln!("{stderr}");
        assert_eq!(code, Some(1), "{stderr}");
        assert!(
            stderr.contains(&file.display().to_string()) && stderr.contains(reason),
            "{stderr}"
        );
    }
}

/// The memo's rig with its motor's torque constant and its amplifier's transconductance
/// `torque` and `amplifier` times the memo's (the drive that many times as strong).
fn drive_scaled(torque: f64, amplifier: f64) -> RigConfig {
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.torque_constant_nm_per_a *= torque;
    p.amplifier_a_per_v *= amplifier;
    let mut cfg = rig();
    cfg.set_applicator(p);
    cfg
}

/// Designs `cfg` and asserts the identification read the drive's gain `gain` (the memo's
/// identifies at 1.00) at every preload, and the loop the targets with a margin: every
/// step after the first into ±1 g within 25 ms (target 30) and at most 0.75 g over (target 1),
/// the touch-downs of `low-force` and from 1 mm off the finger at most 0.75 g over, a 10 g sine
/// about 50 g within ±1 dB at 40 Hz.
fn designed_meets_the_targets(mut cfg: RigConfig, gain: f64, label: &str) {
    let r = design::design_for_rig(&cfg).expect("design");
    let loads: Vec<f32> = r.identified.models.iter().map(|m| m.load_g).collect();
    eprintln!(
        "{label}: static gain {:.3}, stiction {:.2} g, loads {loads:?}",
        r.identified.static_gain, r.identified.stiction_g
    );
    assert_eq!(loads, design::DESIGN_LOADS_G, "{:?}", r.identified.left_out);
    assert!(
        (r.identified.static_gain / gain - 1.0).abs() < 0.05,
        "{r:?}"
    );
    // The stiction at the probe is the file's 10 g·cm over 9 cm, whatever the drive.
    assert!((r.identified.stiction_g - 1.11).abs() < 0.15, "{r:?}");
    cfg.firmware.designed = Some(r.design.config);
    let steps = ticks("force-steps", &cfg);
    let settle = metrics::settling_after_first_s(&steps);
    let over = metrics::step_overshoots_g(&steps);
    eprintln!("{label}: settling after the first {settle:?}, overshoot {over:?}");
    assert!(
        settle.len() >= 18 && settle.iter().all(|t| *t <= 0.025),
        "{settle:?}"
    );
    assert!(over.iter().skip(1).all(|o| o.1 <= 0.75), "{over:?}");
    let low = ticks("low-force", &cfg);
    let landed = metrics::step_overshoots_g(&low);
    eprintln!("{label}: low-force overshoot {landed:?}");
    assert!(landed.iter().all(|o| o.1 <= 0.75), "{landed:?}");
    let t = metrics::touch_down(cfg.clone(), 1e-3, 2.0, 3.0).unwrap();
    eprintln!("{label}: 1 mm → 2 g: {t:?}");
    assert!(t.contact_s.is_some() && t.overshoot_g <= 0.75, "{t:?}");
    magnitude_db(&cfg, &format!("{label}: "), (50.0, 10.0, 40.0), (-1.0, 1.0));
}

#[test]
fn a_drive_weaker_than_the_firmwares_scale_holds_its_preloads_and_meets_the_targets() {
    // The motor's torque constant 0.6× the memo's: A1, which drives the command itself, held
    // 6 g for 10 g; the identification moves the firmware's drive scale to the share it held
    // and reads the drive in the firmware's grams, so the static gain is 0.6.
    designed_meets_the_targets(drive_scaled(0.6, 1.0), 0.6, "torque ×0.6");
}

#[test]
fn a_drive_that_cannot_reach_the_force_steps_is_refused_with_its_reach() {
    // Torque ×0.6 and a 0.12 A/V amplifier: 0.6·0.12/0.19 = 0.379 of the firmware's scale,
    // whose rail is 192 g; less the file's 1.11 g of stiction the probe gets 71.6 g, and the
    // force steps go to 100 g. Before the scale moved, every preload's hold read under half
    // its command and the supervisor stopped each excitation as a contact lost.
    let cfg = drive_scaled(0.6, 0.12 / 0.19);
    match design::design_for_rig(&cfg) {
        Err(e @ design::DesignError::OutOfReach { reach_g, top_g, .. }) => {
            eprintln!("{e}");
            assert!((reach_g - 71.6).abs() < 3.0 && top_g == 100.0, "{e}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_drive_stronger_than_the_firmwares_scale_is_identified_and_designed() {
    // The torque constant 1.5×: A1 held 13.9 g for 10 g, and the 100 g preload's ramp latched
    // the supervisor's force slew. With the stiction counted at the probe, not the drive, the
    // feed-forward pushed 1.5× the friction and the 100 → 90 g step took 33 ms, 1.14 g over.
    designed_meets_the_targets(drive_scaled(1.5, 1.0), 1.5, "torque ×1.5");
}

#[test]
fn a_coarse_gauge_and_a_fast_amplifier_fit_a_pole_the_chirp_can_place() {
    // With a 5.8 g/V gauge and a 400 Hz amplifier every fit put the pole at 10¹⁵ Hz and was
    // refused; held at 500 Hz, the loads the gauge reaches fit.
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.torque_constant_nm_per_a *= 1.5;
    p.gauge_g_per_v = 5.8;
    p.gauge_noise_g = 0.058;
    p.amplifier_pole_hz = 400.0;
    let mut cfg = rig();
    cfg.set_applicator(p);
    let r = design::design_for_rig(&cfg).expect("design");
    let poles: Vec<f64> = r
        .identified
        .models
        .iter()
        .map(|m| m.model.pole_hz)
        .collect();
    eprintln!(
        "5.8 g/V, 400 Hz: poles {poles:?}, left out {:?}",
        r.identified.left_out
    );
    assert!(poles.len() >= 3 && poles.iter().all(|p| (100.0..=500.0).contains(p)));
}

#[test]
fn a_table_designed_through_another_gauge_is_refused_with_both_scales() {
    // The committed table is the memo rig's, its grams those of a 14 g/V gauge reading to
    // 135 g; read by a firmware whose gauge is 28 g/V (to 270 g) its contact reading and loads
    // would be off by two, so the loop is not built and the reason names both gauges.
    let committed = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../boards/controller/table.bin"),
    )
    .unwrap();
    let table = tactile_core::designed::DesignedConfig::decode(&committed).unwrap();
    assert_eq!((table.gauge_g_per_v, table.gauge_max_g), (14.0, 135.0));
    let mut p = sim_host::applicator::ApplicatorParams::MEMO;
    p.gauge_g_per_v = 28.0;
    let mut cfg = rig();
    cfg.set_applicator(p);
    cfg.firmware.designed = Some(table);
    let Err(e) = run_named("force-steps", &ScenarioOptions::default(), cfg, |_| {}) else {
        panic!("a table of another gauge was taken");
    };
    let e = e.to_string();
    eprintln!("{e}");
    assert!(e.contains("14 g/V") && e.contains("28 g/V"), "{e}");
}
