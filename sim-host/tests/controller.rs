//! The designed force controller (issue 13) on the memo's rig: identified from the excitation
//! at six preloads, designed on the host, run by the core's loop on the simulator, against A1
//! on the same rig. Bounds are the figures measured when it was built with a margin
//! (`cargo run --release -p sim-host --example design_controller` prints them); the issue's
//! targets that are not met yet are not asserted (the note says which).

use sim_host::design::{self, Design};
use sim_host::metrics;
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn rig() -> RigConfig {
    RigConfig {
        scan_array: false,
        ..Default::default()
    }
}

fn designed() -> (RigConfig, Design) {
    let base = rig();
    let d = design::design_for_rig(&base).expect("design").design;
    let mut cfg = base;
    cfg.firmware.tracking = Some(d.config);
    (cfg, d)
}

#[test]
fn the_designed_loop_holds_with_twice_its_feedback_gains() {
    // A gain margin of 2.4 on the identified models (2 with the plant 20 % stronger), checked
    // on the simulator's plant, which the design never saw: with kp and ki doubled the loop
    // still holds every load from 3 to 120 g without ringing (RMS of true − command over the
    // last half second of a 1.5 s hold, against the gauge's 0.14 g of noise); at ×4 it rings.
    let (cfg, d) = designed();
    let hold = |gain: f32, load_g: f32| {
        let mut c = cfg.clone();
        let mut t = d.config;
        t.kp *= gain;
        t.ki_per_s *= gain;
        c.firmware.tracking = Some(t);
        let mut rig = sim_host::rig::Rig::new(c).unwrap();
        let ticks: Vec<_> = (0..1500).map(|_| rig.tick(load_g, |_, _| {})).collect();
        metrics::rms(
            &ticks[1000..],
            |r| f64::from(r.true_force_g),
            |_| f64::from(load_g),
        )
    };
    for load_g in [3.0, 10.0, 30.0, 60.0, 100.0, 120.0] {
        let (one, two, four) = (hold(1.0, load_g), hold(2.0, load_g), hold(4.0, load_g));
        eprintln!("{load_g} g: RMS error {one:.3} g, ×2 {two:.3} g, ×4 {four:.3} g");
        assert!(two < 0.5, "{load_g} g: ×2 {two} g");
        // The check has teeth: four times the gains is past the margin.
        assert!(four > 1.0, "{load_g} g: ×4 {four} g");
    }
}

#[test]
fn the_designed_loop_is_flatter_and_lands_softer_than_a1() {
    let (cfg, _) = designed();
    let a1 = rig();
    // Closed-loop magnitude, 10 g about 50 g and about 100 g: within the target's ±1 dB from
    // 0.5 to 40 Hz (measured −0.45…+0.34 dB); A1 peaks near +9 dB at 30 Hz.
    for offset in [50.0, 100.0] {
        for hz in [0.5, 5.0, 10.0, 20.0, 25.0, 30.0, 40.0] {
            let g = metrics::closed_loop_gain(cfg.clone(), offset, 10.0, hz).unwrap();
            let db = 20.0 * g.log10();
            eprintln!("designed, {offset} g, {hz} Hz: {db:+.2} dB");
            assert!(db.abs() <= 1.0, "{offset} g, {hz} Hz: {db:+.2} dB");
        }
    }
    let a1_30 = metrics::closed_loop_gain(a1.clone(), 50.0, 10.0, 30.0).unwrap();
    assert!(20.0 * a1_30.log10() > 6.0);

    // Force steps: every step after the first (from rest) into ±1 g within 40 ms (measured
    // 18–37 ms, the target is 30 ms; A1 takes up to 69 ms), overshoot within 1 g (measured
    // ≤ 0.39 g; A1's up to 4.4 g).
    let o = ScenarioOptions::default();
    let steps = run_named("force-steps", &o, cfg.clone(), |_| {})
        .unwrap()
        .ticks;
    for (level, t) in metrics::step_settling_s(&steps).into_iter().skip(1) {
        let t = t.expect("settles");
        assert!(t <= 0.040, "{level} g: {t} s");
    }
    for (level, over) in metrics::step_overshoots_g(&steps).into_iter().skip(1) {
        assert!(over <= 1.0, "{level} g: overshoot {over} g");
    }

    // Touch-down after a rest (low-force): 8, 6, 4, 2 g overshoot by at most 3 g (measured
    // 1.2–2.0 g; the target is 1 g), where A1 overshoots 6 g by about 20 g.
    let touch = |c: &RigConfig| {
        let ticks = run_named("low-force", &o, c.clone(), |_| {}).unwrap().ticks;
        metrics::step_overshoots_g(&ticks)
            .into_iter()
            .filter(|(level, _)| *level > 0.0)
            .collect::<Vec<_>>()
    };
    let (new, old) = (touch(&cfg), touch(&a1));
    eprintln!("touch-down overshoot, designed {new:?}, A1 {old:?}");
    assert!(new.iter().all(|(_, o)| *o <= 3.0), "{new:?}");
    assert!(old.iter().any(|(_, o)| *o > 10.0), "{old:?}");
}

#[test]
fn the_procedure_works_unchanged_on_other_applicators() {
    // The three rigs of `applicators/`: the memo's, a heavy motor on a soft beam, a light motor
    // with twice the stiction on a stiffer beam. The holds give the static gain (1: the drive's
    // grams are the motor's force at the probe) and the stiction the file has (10 or 20 g·cm
    // on a 9 cm arm: 1.11 or 2.22 g); every force step after the first settles into ±1 g
    // within 40 ms (measured 17–30 ms) and overshoots by at most 1.5 g (measured ≤ 1.21 g).
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../applicators");
    for (file, stiction_g) in [
        ("memo.toml", 1.11),
        ("heavy-motor-soft-beam.toml", 1.11),
        ("light-motor-stiff-beam.toml", 2.22),
    ] {
        let mut cfg = rig();
        cfg.applicator = sim_host::error::read_applicator(&root.join(file)).unwrap();
        let r = design::design_for_rig(&cfg).expect("design");
        let id = &r.identified;
        eprintln!(
            "{file}: static gain {:.3}, stiction {:.2} g",
            id.static_gain, id.stiction_g
        );
        assert!((id.static_gain - 1.0).abs() < 0.02, "{file}: {id:?}");
        assert!(
            (id.stiction_g - stiction_g).abs() < 0.15 * stiction_g,
            "{file}: {} g",
            id.stiction_g
        );
        cfg.firmware.tracking = Some(r.design.config);
        let steps = run_named("force-steps", &ScenarioOptions::default(), cfg, |_| {})
            .unwrap()
            .ticks;
        for (level, t) in metrics::step_settling_s(&steps).into_iter().skip(1) {
            let t = t.expect("settles");
            assert!(t <= 0.040, "{file}, {level} g: {t} s");
        }
        for (level, over) in metrics::step_overshoots_g(&steps).into_iter().skip(1) {
            assert!(over <= 1.5, "{file}, {level} g: overshoot {over} g");
        }
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
        tactile_core::tracking::TrackingConfig::decode(&committed),
        Ok(d.config)
    );
}
