//! Property tests: for every input in range the core's hot-path code gives finite output inside
//! its bounds (the "bad input" list: filter stability is in `filter`'s own tests).

use proptest::prelude::*;
use tactile_core::control::{ActuatorConfig, ForceLawConfig};
use tactile_core::estimator::InverseEstimator;
use tactile_core::filter::LowpassNotchConfig;
use tactile_core::gauge::GaugeFault;
use tactile_core::supervisor::{ForceLoop, ForceLoopConfig, SupervisorConfig};
use tactile_core::viscoelastic::{MaxwellKelvin, SecondOrder};

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -1e6f32..1e6,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MAX),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn the_inverse_model_gives_finite_non_negative_force_for_any_strain(
        a1 in 0.01f64..50.0, a2 in 0.001f64..10.0, b0 in 0.5f64..50.0, b1 in 0.0f64..100.0, b2 in 0.001f64..50.0,
        dt in prop_oneof![Just(0.001f64), Just(0.01), Just(0.1)],
        strains in proptest::collection::vec(any_f32(), 1..400),
    ) {
        let model = SecondOrder { a1, a2, b0, b1, b2 };
        let inv = model.inverse::<f32>(dt).unwrap();
        let mut est = InverseEstimator::new(inv);
        for s in strains {
            let f = est.force_g(s);
            prop_assert!(f.is_finite() && f >= 0.0, "{f} from {s}");
        }
    }

    #[test]
    fn forward_maxwell_kelvin_stays_finite_for_bounded_stress(
        g1 in 0.5f64..20.0, n1 in 100.0f64..1e5, alpha in 0.0f64..50.0, n2 in 10.0f64..5000.0, g2 in 1.0f64..500.0,
        stresses in proptest::collection::vec(-200.0f32..200.0, 1..400),
    ) {
        let fwd = MaxwellKelvin { g1, n1, alpha, n2, g2 }.forward::<f32>(0.001).unwrap();
        let mut st = Default::default();
        for s in stresses {
            prop_assert!(fwd.update(&mut st, s).is_finite());
        }
    }

    #[test]
    fn the_force_loop_never_leaves_its_bounds_whatever_it_is_fed(
        steps in proptest::collection::vec((any_f32(), any_f32(), 0u8..10, any::<bool>()), 1..600),
    ) {
        let mut l = ForceLoop::new(ForceLoopConfig {
            law: ForceLawConfig::MEMO,
            filter: LowpassNotchConfig::MEMO,
            actuator: ActuatorConfig::MEMO,
            supervisor: SupervisorConfig::DESIGN,
            slew_g_per_s: 500.0,
            designed: None,
            gauge_range_g: (-30.0, 135.0),
        }).unwrap();
        for (command, reading, kind, overrun) in steps {
            let reading = match kind {
                0 => Err(GaugeFault::AtRail { code: tactile_core::gauge::AdcCode(0) }),
                1 => Err(GaugeFault::OutOfRange { force_g: reading }),
                _ => Ok(reading),
            };
            let out = l.tick(command, reading, overrun && kind == 9);
            prop_assert!(out.dac_code.0 <= 4095);
            prop_assert!(out.shaped_g.is_finite() && (0.0..=120.0).contains(&out.shaped_g), "{}", out.shaped_g);
            prop_assert!(out.adjusted_g.is_finite() && out.adjusted_g.abs() <= 192.0, "{}", out.adjusted_g);
            // Once latched, the output is the zero code until cleared.
            if !l.latched().is_empty() {
                prop_assert_eq!(out.dac_code, ActuatorConfig::MEMO.zero_code());
            }
        }
    }
}
