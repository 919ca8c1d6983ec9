//! The designed controller's touch-down: the probe starts at rest 0, 0.2 or 1 mm
//! off the finger and the command steps from 0 to 2, 5 or 10 g; prints, per case, when the
//! probe met the finger, the contact force's overshoot over the command and its mean over the
//! last 0.2 s of a 3 s run (`metrics::touch_down`).
//!
//! cargo run --release -p sim-host --example touch_down [applicators/F.toml [STICTION_FACTOR]]
//!
//! `STICTION_FACTOR` scales the file's stiction (0: a rig without friction, which the design
//! never saw; the probe then rests wherever it is left).
use sim_host::rig::RigConfig;
use sim_host::{design, metrics};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let file = args
        .first()
        .cloned()
        .unwrap_or_else(|| "applicators/memo.toml".into());
    let mut cfg = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    cfg.set_applicator(
        sim_host::error::read_applicator(std::path::Path::new(&file))
            .unwrap_or_else(|e| panic!("{file}: {e}")),
    );
    if let Some(f) = args.get(1).and_then(|f| f.parse::<f64>().ok()) {
        cfg.applicator.static_friction_nm *= f;
    }
    let r = design::design_for_rig(&cfg).expect("design");
    let c = r.design.config;
    println!(
        "{file}: stiction identified {:.2} g; pulses on {:.2} g, push +{:.2} g, brake {:.2} g, contact at {:.2} g",
        r.identified.stiction_g, c.approach_hold_g, c.approach_push_g, c.approach_brake_g, c.contact_g
    );
    cfg.firmware.designed = Some(c);
    for gap_mm in [0.0, 0.2, 1.0] {
        for target_g in [2.0f32, 5.0, 10.0] {
            let t = metrics::touch_down(cfg.clone(), gap_mm * 1e-3, target_g, 3.0).expect("rig");
            let contact = t
                .contact_s
                .map_or("never".into(), |s| format!("after {:4.0} ms", 1e3 * s));
            println!(
                "  {gap_mm:.1} mm off, 0 → {target_g:4.1} g: on the finger {contact}, overshoot {:+.2} g, last 0.2 s {:.2} g",
                t.overshoot_g, t.final_g
            );
        }
    }
}
