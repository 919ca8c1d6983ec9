//! The 1 kHz control tick: the command source, the slew limiter, A1 on the averaged gauge, the
//! lowpass-notch filter and the DAC; plus the probed element's strain and inverse-model force.
//! The same order of operations as the simulator's rig, so a simulated board reproduces the
//! simulator's traces.

use tactile_core::gauge::{AdcScale, GaugeConfig, GaugeFault};
use tactile_core::profile::{CommandSource, Protocol};
use tactile_core::supervisor::{ForceLoop, ForceLoopConfig};
use tactile_core::tactile::{StrainForm, TaxelCalibration};
use tactile_core::telemetry::{ControlFrame, FaultFlags};
use tactile_core::viscoelastic::InverseEstimator;

use crate::board::ControlIo;
use crate::config::{ConfigError, FirmwareConfig, CONTROL_PERIOD_S};

/// State of the control task for one run of a protocol.
#[derive(Clone, Debug)]
pub struct Controller {
    source: CommandSource,
    /// Command check, slew limiter, A1, filter, DAC and the fault table (core library).
    force_loop: ForceLoop,
    gauge: GaugeConfig,
    taxel_adc: AdcScale,
    probe_calibration: TaxelCalibration,
    estimator: InverseEstimator,
    /// Ticks run since the protocol started (the command source's clock).
    ticks: u32,
    overruns: u32,
    overrun_pending: bool,
}

impl Controller {
    /// A controller for `protocol`, with the probed element's rest calibration. Commands are
    /// slewed at the protocol's limit, as the simulator's scenarios do.
    pub fn new(
        config: &FirmwareConfig,
        protocol: Protocol,
        probe_calibration: TaxelCalibration,
    ) -> Result<Self, ConfigError> {
        let force_loop = ForceLoop::new(ForceLoopConfig {
            law: config.law,
            filter: config.filter,
            actuator: config.actuator,
            supervisor: config.supervisor,
            slew_g_per_s: protocol.slew_limit_g_per_s(),
        })
        .map_err(ConfigError::Filter)?;
        let inverse = config
            .estimator
            .inverse(CONTROL_PERIOD_S)
            .map_err(ConfigError::Estimator)?;
        Ok(Self {
            source: CommandSource::new(protocol),
            force_loop,
            gauge: config.gauge,
            taxel_adc: config.taxel_adc,
            probe_calibration,
            estimator: InverseEstimator::new(inverse),
            ticks: 0,
            overruns: 0,
            overrun_pending: false,
        })
    }

    /// Ticks since the protocol started.
    pub fn ticks(&self) -> u32 {
        self.ticks
    }

    /// True once the protocol's duration has elapsed.
    pub fn finished(&self) -> bool {
        f64::from(self.ticks) * CONTROL_PERIOD_S >= f64::from(self.source.protocol().duration_s())
    }

    /// The board's timer saw a deadline missed; the next frame carries the flag.
    pub fn record_overrun(&mut self) {
        self.overruns = self.overruns.saturating_add(1);
        self.overrun_pending = true;
    }

    pub fn overruns(&self) -> u32 {
        self.overruns
    }

    /// Latched faults of the force loop (the actuator is held at zero while any is set).
    pub fn latched(&self) -> FaultFlags {
        self.force_loop.latched()
    }

    /// The explicit command that clears latched faults.
    pub fn clear_faults(&mut self) {
        self.force_loop.clear_faults();
    }

    /// One control tick at board time `board_tick`. Reads the last period's gauge samples and
    /// probe channel, writes the DAC, and returns the frame (sequence number unset: the
    /// outbox numbers it).
    pub fn tick(&mut self, io: &mut impl ControlIo, board_tick: u32) -> ControlFrame {
        let mut faults = FaultFlags::NONE;
        let (reading, strain_pct, estimate_g) = if self.ticks == 0 {
            // No sampling period has completed yet: the law starts from an unloaded gauge
            // (the simulator's rig starts the same way).
            (Ok(0.0), 0.0, 0.0)
        } else {
            let codes = io.read_gauge();
            let volts = self.taxel_adc.volts(io.read_probe_channel());
            let strain = self.probe_calibration.strain_pct(volts, StrainForm::Exact);
            (
                self.gauge.average_force(&codes),
                strain,
                self.estimator.force_g(strain),
            )
        };
        // The command source's clock, computed as the simulator computes it.
        let t_s = (f64::from(self.ticks) * CONTROL_PERIOD_S) as f32;
        let command_g = self.source.command_g(t_s);
        let overrun = core::mem::take(&mut self.overrun_pending);
        let out = self.force_loop.tick(command_g, reading, overrun);
        io.write_actuator(out.dac_code);
        faults.insert(out.faults.0);
        let adjusted_g = out.adjusted_g;
        self.ticks = self.ticks.saturating_add(1);
        ControlFrame {
            seq: 0,
            tick: board_tick,
            command_g,
            sensed_g: match reading {
                Ok(f) | Err(GaugeFault::OutOfRange { force_g: f }) => f,
                Err(GaugeFault::AtRail { code }) => self.gauge.force_g(self.gauge.adc.volts(code)),
            },
            adjusted_g,
            strain_pct,
            estimate_g,
            faults,
        }
    }
}
