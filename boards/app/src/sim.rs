//! The simulated board of `tactile-plant` behind the firmware's hardware traits, for the
//! firmware-in-the-loop build (QEMU) and the host check that the task bodies reproduce the
//! simulator's rig.

use tactile_core::gauge::{AdcCode, SAMPLES_PER_TICK};
use tactile_core::tactile::TaxelId;
use tactile_plant::hardware::SimHardware;
use tactile_plant::rig::RigConfig;

use crate::board::{ControlIo, ScanIo};
use crate::config::FirmwareConfig;

impl FirmwareConfig {
    /// The configuration of a simulator rig (`RigConfig::default()` for the simulator's own
    /// runs), so firmware and simulator traces agree.
    pub fn from_rig(rig: &RigConfig) -> Self {
        FirmwareConfig {
            law: rig.law,
            filter: rig.filter,
            gauge: rig.gauge,
            actuator: rig.actuator,
            taxel_adc: rig.readout.adc,
            scan: rig.readout.scan,
            probe: rig.probe,
            estimator: rig.estimator,
            supervisor: rig.supervisor,
        }
    }
}

impl ControlIo for SimHardware {
    fn read_gauge(&mut self) -> [AdcCode; SAMPLES_PER_TICK] {
        self.gauge_codes()
    }
    fn read_probe_channel(&mut self) -> AdcCode {
        self.probe_code()
    }
    fn write_actuator(&mut self, code: AdcCode) {
        self.write_dac(code);
    }
}

impl ScanIo for SimHardware {
    fn select_taxel(&mut self, taxel: TaxelId) {
        SimHardware::select_taxel(self, taxel);
    }
    fn read_taxel(&mut self) -> AdcCode {
        self.sample_selected_taxel()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Controller;
    use crate::scan::Scanner;
    use tactile_core::profile::Protocol;
    use tactile_core::telemetry::TaxelFrame;
    use tactile_plant::rig::Rig;

    /// The task bodies on the simulated board, in the order the QEMU build runs them (control,
    /// one period of physics, four scan steps), against the simulator's rig: the same numbers
    /// to the bit, one tick apart where the rig reports after the physics.
    fn replay(protocol: Protocol, seconds: usize) {
        let config = RigConfig {
            command_slew_g_per_s: protocol.slew_limit_g_per_s(),
            ..RigConfig::default()
        };
        let fw = FirmwareConfig::from_rig(&config);
        let mut rig = Rig::new(config.clone()).unwrap();
        let mut hw = SimHardware::new(&config);
        let calibration = *hw.calibration();
        let mut controller = Controller::new(&fw, protocol, calibration[fw.probe.index()]).unwrap();
        let mut scanner = Scanner::new(&fw, calibration).unwrap();
        scanner.start(&mut hw);
        let mut source = tactile_core::profile::CommandSource::new(protocol);
        let (mut rig_frames, mut fw_frames) = (Vec::new(), Vec::new());
        let mut previous = None;
        for k in 0..(seconds * 1000) as u32 {
            let frame = controller.tick(&mut hw, k);
            hw.advance_period();
            for _ in 0..4 {
                if let Some(r) = scanner.step(&mut hw, k) {
                    fw_frames.push(r.frame);
                }
            }
            let command = source.command_g(rig.time_s() as f32);
            let rec = rig.tick(command, |_, grid| rig_frames.push(*grid));
            assert_eq!(frame.command_g, rec.command_g, "tick {k}");
            assert_eq!(frame.adjusted_g, rec.adjusted_g, "tick {k}");
            if let Some(prev) = previous.replace(rec) {
                let prev: tactile_plant::rig::TickRecord = prev;
                assert_eq!(frame.sensed_g, prev.sensed_g, "tick {k}");
                assert_eq!(frame.strain_pct, prev.strain_pct, "tick {k}");
                assert_eq!(frame.estimate_g, prev.estimate_g, "tick {k}");
            }
            assert_eq!(hw.true_force_g() as f32, rec.true_force_g, "tick {k}");
        }
        assert_eq!(fw_frames.len(), rig_frames.len());
        assert!(fw_frames.len() >= seconds * 62);
        for (f, g) in fw_frames.iter().zip(&rig_frames) {
            for (cells, row) in f.strain_centi_pct.iter().zip(g) {
                for (&cell, &strain) in cells.iter().zip(row) {
                    assert_eq!(cell, TaxelFrame::quantize(strain));
                }
            }
        }
        assert_eq!(controller.overruns(), 0);
    }

    #[test]
    fn the_task_bodies_on_the_simulated_board_are_the_simulators_rig() {
        replay(Protocol::FORCE_STEPS_MEMO, 11);
        replay(Protocol::PSEUDO_RANDOM_MEMO, 10);
    }
}
