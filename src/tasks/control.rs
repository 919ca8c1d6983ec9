//! The 1 kHz control tick: A1 on the averaged gauge, the lowpass-notch filter and the DAC, plus
//! the probed element's strain and inverse-model force.
//!
//! One period of a board is `act → the hardware runs → sense`: [`ControlLoop::act`] runs the
//! law on the reading of the period before and writes the DAC, [`ControlLoop::sense`] reads
//! what the converters took during the period. The firmware's [`Controller`] senses at the top
//! of each tick (the samples of the period that just ended) and takes its command from a
//! protocol; the simulator's rig acts with its scenario's command and senses after its
//! physics. Both run these two functions in the same order, so they agree by construction.

use crate::estimator::InverseEstimator;
use crate::gauge::{AdcScale, GaugeConfig, GaugeFault};
use crate::io::ControlIo;
use crate::profile::{CommandSource, Protocol};
use crate::supervisor::{ForceLoop, ForceLoopConfig};
use crate::tactile::{StrainForm, TaxelCalibration};
use crate::telemetry::{ControlFrame, FaultFlags};
use crate::CONTROL_PERIOD_S;

use super::config::{ConfigError, FirmwareConfig};

/// What one period's converters gave the control task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// The gauge's averaged force, or why it is not usable.
    pub gauge: Result<f32, GaugeFault>,
    /// The probed element's strain, percent.
    pub strain_pct: f32,
    /// The probed element's force by the inverse model, grams.
    pub estimate_g: f32,
}

impl Reading {
    /// Before the first period: an unloaded gauge, no strain.
    pub const REST: Reading = Reading {
        gauge: Ok(0.0),
        strain_pct: 0.0,
        estimate_g: 0.0,
    };

    /// The force the gauge read, grams: on a fault, the raw reading (the fault is flagged
    /// elsewhere).
    pub fn sensed_g(&self, gauge: &GaugeConfig) -> f32 {
        match self.gauge {
            Ok(f) | Err(GaugeFault::OutOfRange { force_g: f }) => f,
            Err(GaugeFault::AtRail { code }) => gauge.force_g(gauge.adc.volts(code)),
        }
    }
}

/// The control loop without a command source: sense, then act, once a period.
#[derive(Clone, Debug)]
pub struct ControlLoop {
    /// Command check, slew limiter, A1, filter, DAC and the fault table.
    force_loop: ForceLoop,
    gauge: GaugeConfig,
    taxel_adc: AdcScale,
    probe_calibration: TaxelCalibration,
    estimator: InverseEstimator,
    /// The last period's reading: what the law runs on next.
    reading: Reading,
    overruns: u32,
    overrun_pending: bool,
}

impl ControlLoop {
    /// A loop whose commands are slewed at `slew_g_per_s`, with the probed element's rest
    /// calibration.
    pub fn new(
        config: &FirmwareConfig,
        slew_g_per_s: f32,
        probe_calibration: TaxelCalibration,
    ) -> Result<Self, ConfigError> {
        if let Some(d) = config.designed {
            let g = config.gauge;
            if d.gauge_g_per_v != g.grams_per_volt || d.gauge_max_g != g.force_max_g {
                return Err(ConfigError::DesignedGauge {
                    table_g_per_v: d.gauge_g_per_v,
                    table_max_g: d.gauge_max_g,
                    firmware_g_per_v: g.grams_per_volt,
                    firmware_max_g: g.force_max_g,
                });
            }
        }
        let force_loop = ForceLoop::new(ForceLoopConfig {
            law: config.law,
            filter: config.filter,
            actuator: config.actuator,
            supervisor: config.supervisor,
            slew_g_per_s,
            designed: config.designed,
            gauge_range_g: (config.gauge.force_min_g, config.gauge.force_max_g),
        })?;
        let inverse = config
            .estimator
            .inverse(CONTROL_PERIOD_S)
            .map_err(ConfigError::Estimator)?;
        Ok(Self {
            force_loop,
            gauge: config.gauge,
            taxel_adc: config.taxel_adc,
            probe_calibration,
            estimator: InverseEstimator::new(inverse),
            reading: Reading::REST,
            overruns: 0,
            overrun_pending: false,
        })
    }

    /// Reads the gauge samples and the probe channel the converters took during the period
    /// that just ended; the next [`Self::act`] runs the law on them.
    pub fn sense(&mut self, io: &mut impl ControlIo) -> Reading {
        let codes = io.read_gauge();
        let volts = self.taxel_adc.volts(io.read_probe_channel());
        let strain_pct = self.probe_calibration.strain_pct(volts, StrainForm::Exact);
        self.reading = Reading {
            gauge: self.gauge.average_force(&codes),
            strain_pct,
            estimate_g: self.estimator.force_g(strain_pct),
        };
        self.reading
    }

    /// The law on the last reading with command `command_g`: writes the DAC and returns the
    /// frame (sequence number unset: the outbox numbers it).
    pub fn act(
        &mut self,
        io: &mut impl ControlIo,
        command_g: f32,
        board_tick: u32,
    ) -> ControlFrame {
        let overrun = core::mem::take(&mut self.overrun_pending);
        let out = self.force_loop.tick(command_g, self.reading.gauge, overrun);
        io.write_actuator(out.dac_code);
        ControlFrame {
            seq: 0,
            tick: board_tick,
            command_g,
            sensed_g: self.reading.sensed_g(&self.gauge),
            adjusted_g: out.adjusted_g,
            strain_pct: self.reading.strain_pct,
            estimate_g: self.reading.estimate_g,
            dac_code: out.dac_code.0,
            faults: out.faults,
        }
    }

    /// A deadline was missed; the next frame carries the flag.
    pub fn record_overrun(&mut self) {
        self.overruns = self.overruns.saturating_add(1);
        self.overrun_pending = true;
    }

    /// The chirp added to the drive after the filter (see [`ForceLoop::set_drive_excitation`]).
    pub fn set_drive_excitation(&mut self, chirp: Option<crate::profile::ChirpSample>) {
        self.force_loop.set_drive_excitation(chirp);
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
}

/// The firmware's control task for one run of a protocol: the protocol's command at the
/// task's own clock into the [`ControlLoop`].
#[derive(Clone, Debug)]
pub struct Controller {
    source: CommandSource,
    control: ControlLoop,
    /// Ticks run since the protocol started (the command source's clock).
    ticks: u32,
}

impl Controller {
    /// A controller for `protocol`, with the probed element's rest calibration. Commands are
    /// slewed at the protocol's limit, as the simulator's scenarios do.
    pub fn new(
        config: &FirmwareConfig,
        protocol: Protocol,
        probe_calibration: TaxelCalibration,
    ) -> Result<Self, ConfigError> {
        Ok(Self {
            source: CommandSource::new(protocol),
            control: ControlLoop::new(config, protocol.slew_limit_g_per_s(), probe_calibration)?,
            ticks: 0,
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

    /// One control tick at board time `board_tick`: senses the period that just ended (none
    /// has before the first tick), runs the law on the protocol's command, writes the DAC.
    pub fn tick(&mut self, io: &mut impl ControlIo, board_tick: u32) -> ControlFrame {
        if self.ticks > 0 {
            self.control.sense(io);
        }
        // The command source's clock, computed as the simulator's rig computes it.
        let t_s = (f64::from(self.ticks) * CONTROL_PERIOD_S) as f32;
        let command_g = self.source.command_g(t_s);
        self.control.set_drive_excitation(self.source.chirp(t_s));
        self.ticks = self.ticks.saturating_add(1);
        self.control.act(io, command_g, board_tick)
    }

    /// The board's timer saw a deadline missed; the next frame carries the flag.
    pub fn record_overrun(&mut self) {
        self.control.record_overrun();
    }

    pub fn overruns(&self) -> u32 {
        self.control.overruns()
    }

    /// Latched faults of the force loop (the actuator is held at zero while any is set).
    pub fn latched(&self) -> FaultFlags {
        self.control.latched()
    }

    /// The explicit command that clears latched faults.
    pub fn clear_faults(&mut self) {
        self.control.clear_faults();
    }
}
