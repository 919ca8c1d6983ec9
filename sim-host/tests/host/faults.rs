//! Fault injection: every sensor and timing fault drives the motor to a safe output within
//! 2 ms, the right fault code shows in the record, and the probe force falls to zero.

use sim_host::rig::{FaultInjection, InjectedFault, RigConfig, TickRecord};
use sim_host::scenario::run_protocol;
use tactile_core::control::ActuatorConfig;
use tactile_core::profile::Protocol;
use tactile_core::telemetry::FaultFlags;

const INJECT_S: f64 = 2.0;

fn run(protocol: Protocol, fault: InjectedFault, at_s: f64) -> Vec<TickRecord> {
    let config = RigConfig {
        fault: Some(FaultInjection { fault, at_s }),
        ..Default::default()
    };
    run_protocol("fault", protocol, config, false, |_| {})
        .unwrap()
        .ticks
}

fn hold_30g() -> Protocol {
    Protocol::Step {
        load_g: 30.0,
        lead_s: 0.2,
        on_s: 4.0,
        off_s: 0.5,
    }
}

/// Index of the first tick that starts at or after `t` (records carry the tick's end time).
fn tick_at(ticks: &[TickRecord], t: f64) -> usize {
    ticks.iter().position(|r| r.t_s - 1e-3 >= t - 1e-9).unwrap()
}

/// The tick, counted from the injection, at which the output became the zero code for good.
fn safe_after(ticks: &[TickRecord], from: usize) -> Option<usize> {
    let zero = ActuatorConfig::MEMO.zero_code().0;
    let last_not_zero = ticks[from..].iter().rposition(|r| r.dac_code != zero);
    match last_not_zero {
        None => Some(0),
        Some(i) if i + 1 < ticks.len() - from => Some(i + 1),
        Some(_) => None,
    }
}

/// `within_ticks`: the output must be safe in that many ticks of the injection (a sensor fault
/// shows in the reading the next tick uses); `latch_ticks`: by when the fault is latched.
fn assert_safe_and_released(
    ticks: &[TickRecord],
    fault: FaultFlags,
    within_ticks: usize,
    latch_ticks: usize,
) {
    let k0 = tick_at(ticks, INJECT_S);
    let safe = safe_after(ticks, k0).expect("the output goes to zero and stays there");
    assert!(safe < within_ticks, "safe after {safe} ticks");
    let flagged = ticks[k0..=k0 + latch_ticks]
        .iter()
        .any(|r| r.faults.contains(fault | FaultFlags::LATCHED));
    assert!(
        flagged,
        "fault {:?} not latched in time: {:?}",
        fault.names().collect::<Vec<_>>(),
        ticks[k0 + latch_ticks].faults.names().collect::<Vec<_>>()
    );
    // The probe retracts: force below 0.5 g within 150 ms and zero by the end.
    let released = ticks[k0..]
        .iter()
        .position(|r| r.true_force_g < 0.5)
        .expect("force falls");
    assert!(
        released < 150,
        "force still {} g after {released} ms",
        ticks[k0 + released.min(149)].true_force_g
    );
    assert!(ticks.last().unwrap().true_force_g < 0.1);
    // Latched to the end of the run.
    assert!(ticks.last().unwrap().faults.contains(FaultFlags::LATCHED));
}

/// A disconnected or saturated gauge and a force spike are safe within 2 ms, an overrun in the
/// same period: (the fault, its flag, safe within ticks, latched by ticks).
#[test]
fn faults_in_a_hold_are_safe_within_2_ms() {
    for (fault, flag, within_ticks, latch_ticks) in [
        // Safe on the first bad reading (the tick after the wire breaks), latched on the second.
        (
            InjectedFault::GaugeDisconnected,
            FaultFlags::GAUGE_AT_RAIL,
            2,
            2,
        ),
        (
            InjectedFault::GaugeSaturated,
            FaultFlags::GAUGE_AT_RAIL,
            2,
            2,
        ),
        (
            InjectedFault::ForceSpike { g: 80.0 },
            FaultFlags::FORCE_SLEW,
            2,
            1,
        ),
        (
            InjectedFault::DeadlineOverrun,
            FaultFlags::DEADLINE_OVERRUN,
            1,
            0,
        ),
    ] {
        let t = run(hold_30g(), fault, INJECT_S);
        assert_safe_and_released(&t, flag, within_ticks, latch_ticks);
    }
}

#[test]
fn a_stuck_gauge_is_caught_when_the_command_moves() {
    // Force steps change the command every 0.5 s; the gauge freezes at 2.2 s, the command
    // moves at 2.5 s, and the rule (50 identical readings, command moved by 1 g) fires by then.
    let t = run(Protocol::FORCE_STEPS_MEMO, InjectedFault::GaugeStuck, 2.2);
    let k_move = tick_at(&t, 2.5);
    let latched = t[k_move..].iter().position(|r| {
        r.faults
            .contains(FaultFlags::GAUGE_STUCK | FaultFlags::LATCHED)
    });
    assert!(matches!(latched, Some(k) if k <= 3), "{latched:?}");
    let zero = ActuatorConfig::MEMO.zero_code().0;
    assert!(t[k_move + 4..].iter().all(|r| r.dac_code == zero));
}

#[test]
fn lost_contact_reapproaches_gently_then_latches() {
    // The finger is taken away: the probe cannot find it.
    let protocol = Protocol::Step {
        load_g: 30.0,
        lead_s: 0.2,
        on_s: 6.0,
        off_s: 0.5,
    };
    let t = run(
        protocol,
        InjectedFault::ContactLost {
            strain_pct: f64::INFINITY,
        },
        INJECT_S,
    );
    let k0 = tick_at(&t, INJECT_S);
    let approach = t[k0..]
        .iter()
        .position(|r| r.faults.contains(FaultFlags::APPROACHING))
        .expect("re-approach");
    assert!(approach < 100, "{approach}");
    // Bounded: while approaching the law is given 2 g. In the air the beam rings, so a release
    // can be premature; the command then ramps from the reading, not from 30 g, and the search
    // goes on. Over the search the drive averages a small fraction of the 30 g command.
    let during = &t[k0 + approach..k0 + approach + 1500];
    let approaching = during
        .iter()
        .filter(|r| r.faults.contains(FaultFlags::APPROACHING));
    assert!(approaching.clone().all(|r| r.adjusted_g <= 3.0));
    let searching = approaching.count();
    assert!(searching > 500, "{searching} of 1500 ticks approaching");
    let mean_drive = during.iter().map(|r| r.adjusted_g).sum::<f32>() / during.len() as f32;
    assert!(mean_drive < 7.5, "mean drive {mean_drive} g");
    // Not latched at once; latched after 2 s of searching, with zero output.
    assert!(!t[k0 + approach + 10].faults.contains(FaultFlags::LATCHED));
    let latched = t[k0..]
        .iter()
        .position(|r| {
            r.faults
                .contains(FaultFlags::CONTACT_LOST | FaultFlags::LATCHED)
        })
        .expect("latched");
    assert!(
        (2000..2200).contains(&latched),
        "{latched}: {:?}",
        t[k0 + latched].faults.names().collect::<Vec<_>>()
    );
}

#[test]
fn a_nan_command_is_rejected_and_flagged_without_latching() {
    let t = run(hold_30g(), InjectedFault::CommandNan, INJECT_S);
    let k0 = tick_at(&t, INJECT_S);
    assert!(t[k0].faults.contains(FaultFlags::INVALID_INPUT));
    assert!(t.iter().all(|r| !r.faults.contains(FaultFlags::LATCHED)));
    assert!(t
        .iter()
        .all(|r| r.adjusted_g.is_finite() && r.command_g.is_finite()));
}

#[test]
fn an_open_taxel_is_marked_bad_in_the_frames() {
    let config = RigConfig {
        fault: Some(FaultInjection {
            fault: InjectedFault::TaxelOpen { index: 27 },
            at_s: 1.0,
        }),
        ..Default::default()
    };
    let run = run_protocol("fault", hold_30g(), config, false, |_| {}).unwrap();
    let (before, after): (Vec<_>, Vec<_>) = run.frames.iter().partition(|(t, _)| *t < 1.0);
    assert!(before.iter().all(|(_, g)| g[3][3].is_finite()));
    assert!(after
        .iter()
        .skip(1)
        .all(|(_, g)| g[3][3].is_nan() && g[3][2].is_finite()));
    assert!(run
        .ticks
        .iter()
        .any(|r| r.faults.contains(FaultFlags::TAXEL_AT_RAIL)));
    // A bad taxel is not a reason to stop the force loop.
    assert!(run
        .ticks
        .iter()
        .all(|r| !r.faults.contains(FaultFlags::LATCHED)));
}
