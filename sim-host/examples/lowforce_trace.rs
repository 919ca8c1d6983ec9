//! `low-force` (8, 6, 4, 2 g, each after a second's rest, held 3 s) under the designed
//! controller, tick by tick: command, drive, contact force, gauge reading and where the probe
//! tip and the motor are (0: the finger's surface at rest; negative: off it). What showed the
//! heavy rig's first rest throwing the probe 9.5 mm off the finger.
//!
//! cargo run --release -p sim-host --example lowforce_trace -- applicators/F.toml FROM_S TO_S EVERY
//!
//! `STEPS=1`: `force-steps` instead. `SINE=L:A:HZ`: a sine of A g at HZ about L g instead
//! (L ramped up over the first second, then L + A·sin(2π·HZ·t), as
//! `metrics::closed_loop_gain` runs it).
use sim_host::design;
use sim_host::rig::{Rig, RigConfig};
use tactile_core::profile::{CommandSource, Protocol};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: f64| a.get(i).and_then(|v| v.parse().ok()).unwrap_or(default);
    let mut config = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    let file = a.first().map_or("applicators/memo.toml", |s| s.as_str());
    config.set_applicator(
        sim_host::error::read_applicator(std::path::Path::new(file))
            .unwrap_or_else(|e| panic!("{file}: {e}")),
    );
    config.firmware.designed = Some(
        design::design_for_rig(&config)
            .expect("design")
            .design
            .config,
    );
    let (from_s, to_s, every) = (arg(1, 3.9), arg(2, 5.4), arg(3, 10.0) as usize);
    if std::env::var("SINE").is_ok() {
        config.command_slew_g_per_s = f32::INFINITY;
    }
    let mut rig = Rig::new(config).expect("rig");
    // `STEPS=1`: the force steps instead.
    let protocol = if std::env::var("STEPS").is_ok() {
        Protocol::FORCE_STEPS_MEMO
    } else {
        Protocol::LowForce { hold_s: 3.0 }
    };
    let mut source = CommandSource::new(protocol);
    let sine: Option<[f64; 3]> = std::env::var("SINE").ok().map(|v| {
        let parts: Vec<f64> = v.split(':').filter_map(|x| x.parse().ok()).collect();
        parts
            .try_into()
            .unwrap_or_else(|_| panic!("SINE={v}: give LOAD:AMPLITUDE:HZ, three numbers"))
    });
    for k in 0..(to_s * 1e3) as usize {
        let t_s = k as f64 * 1e-3;
        let command_g = match sine {
            Some([load, _, _]) if t_s < 1.0 => (load * t_s) as f32,
            Some([load, amp, hz]) => {
                (load + amp * (2.0 * std::f64::consts::PI * hz * t_s).sin()) as f32
            }
            None => source.command_g(t_s as f32),
        };
        let r = rig.tick(command_g, |_, _| {});
        if t_s >= from_s && k % every.max(1) == 0 {
            let (tip_m, motor_m) = rig.hardware.positions_m();
            println!(
                "{t_s:7.3} cmd {command_g:4.1} drive {:6.2} true {:6.2} sensed {:6.2} tip {:7.3} mm motor {:7.3} mm",
                r.adjusted_g,
                r.true_force_g,
                r.sensed_g,
                tip_m * 1e3,
                motor_m * 1e3
            );
        }
    }
}
