//! The DISC1's hardware layer: clocks, the converters and the multiplexer lines, behind the
//! firmware's `ControlIo` and `ScanIo`. Pins and analog scaling: `boards/README.md`.
//!
//! Every analog signal of the memo is ±10 V. The front end maps ±10 V onto the converters'
//! 0–3.0 V (VREF+ = VDD = 3.0 V on the DISC1) with V_adc = 1.5 V + 0.15 · V_signal, and the DAC's
//! 0–3.0 V back onto ±10 V with V_signal = 6.67 · (V_dac − 1.5 V). Code 0 is then −10 V and
//! code 4095 is +10 V at either end: the core's `AdcScale::BIPOLAR_10V_12BIT`, so no constant
//! of the firmware changes for the level shifting.

use stm32f4xx_hal::adc::config::{AdcConfig, Clock, SampleTime};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::dac::{DacExt, DacOut, DacPin, C1};
use stm32f4xx_hal::gpio::{Analog, Output, Pin, PA1, PA2, PA3};
use stm32f4xx_hal::pac::{self, ADC1, TIM2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::timer::CounterHz;
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use tactile_core::gauge::{AdcCode, SAMPLES_PER_TICK};
use tactile_core::profile::Protocol;
use tactile_core::tactile::{ReadoutAmplifier, TaxelCalibration, TaxelId, TAXELS};
use tactile_firmware::{ControlIo, ResetCause, SafeStop, ScanIo};

/// Core clock, Hz (HSE 8 MHz crystal of the DISC1 through the PLL).
pub const CORE_HZ: u32 = 168_000_000;

/// The protocol this build runs and its name (the first protocol feature set, in this order).
const CHOSEN: (Protocol, &str) = if cfg!(feature = "protocol-force-steps") {
    (Protocol::FORCE_STEPS_MEMO, "force-steps")
} else if cfg!(feature = "protocol-pseudo-random") {
    (Protocol::PSEUDO_RANDOM_MEMO, "pseudo-random")
} else if cfg!(feature = "protocol-sines") {
    (Protocol::SINES_MEMO, "sines")
} else if cfg!(feature = "protocol-excitation") {
    (Protocol::EXCITATION_MEMO, "excitation")
} else {
    (Protocol::StepLoads, "step-loads")
};
pub const PROTOCOL: Protocol = CHOSEN.0;
pub const PROTOCOL_NAME: &str = CHOSEN.1;
#[cfg(not(any(
    feature = "protocol-force-steps",
    feature = "protocol-pseudo-random",
    feature = "protocol-sines",
    feature = "protocol-step-loads",
    feature = "protocol-excitation"
)))]
compile_error!("choose a protocol feature (protocol-force-steps is the default)");

/// Multiplexer address lines: row bits on PE7–PE9, column bits on PE10–PE12.
const ROW_SHIFT: u32 = 7;
const COL_SHIFT: u32 = 10;
const ADDRESS_MASK: u32 = 0b111;

/// The one converter both tasks use (the HAL calibrates and drives ADC1 only); each task
/// borrows it for its conversions.
pub type Converter = Adc<ADC1>;

/// The strain gauge (PA1, ADC1 IN1), the probed element's channel (PA2, ADC1 IN2) and the
/// DAC to the current amplifier (PA4, DAC_OUT1).
pub struct ControlBoard {
    gauge: PA1<Analog>,
    probe: PA2<Analog>,
    dac: C1,
}

/// Multiplexer address lines: rows PE7–PE9, columns PE10–PE12.
type AddressLines = (
    Pin<'E', 7, Output>,
    Pin<'E', 8, Output>,
    Pin<'E', 9, Output>,
    Pin<'E', 10, Output>,
    Pin<'E', 11, Output>,
    Pin<'E', 12, Output>,
);

/// The scanned taxel's channel (PA3, ADC1 IN3) and the multiplexer lines.
pub struct ScanBoard {
    taxel: PA3<Analog>,
    /// PE7–PE12, configured as push-pull outputs; written together through BSRR.
    _address: AddressLines,
}

pub struct Hardware {
    pub adc: Converter,
    pub control_board: ControlBoard,
    pub scan_board: ScanBoard,
    /// TIM2: the scan's dwell timer.
    pub scan_timer: CounterHz<TIM2>,
    /// The independent watchdog, not started yet (it runs on the LSI, independent of the
    /// core clock, and cannot be stopped once started).
    pub watchdog: IndependentWatchdog,
    /// Why the chip last reset (RCC_CSR, read before its flags are cleared).
    pub reset_cause: ResetCause,
}

/// Clocks, pins and converters.
pub fn setup(dp: pac::Peripherals) -> Hardware {
    let reset_cause = ResetCause::from_rcc_csr(dp.RCC.csr().read().bits());
    // Clear the flags, so the next boot reports only its own reset.
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    let watchdog = IndependentWatchdog::new(dp.IWDG);
    // A debugger's halt must not count as a hang.
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    let mut rcc = dp.RCC.freeze(
        Config::hse(8.MHz())
            .sysclk(CORE_HZ.Hz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    );
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiod = dp.GPIOD.split(&mut rcc);
    let gpioe = dp.GPIOE.split(&mut rcc);
    // PA4 is also the audio codec's I2S word clock on the DISC1: hold the codec in reset
    // (PD4 low) so it leaves the line to the DAC.
    let mut codec_reset = gpiod.pd4.into_push_pull_output();
    codec_reset.set_low();
    // ADC clock 84 MHz / 4 = 21 MHz (the converter's limit is 36 MHz).
    let adc_config = AdcConfig::default().clock(Clock::Pclk2_div_4);
    let mut dac = dp.DAC.constrain(gpioa.pa4.into_analog(), &mut rcc);
    dac.enable();
    Hardware {
        adc: Adc::new(dp.ADC1, true, adc_config, &mut rcc),
        control_board: ControlBoard {
            gauge: gpioa.pa1.into_analog(),
            probe: gpioa.pa2.into_analog(),
            dac,
        },
        scan_board: ScanBoard {
            taxel: gpioa.pa3.into_analog(),
            _address: (
                gpioe.pe7.into_push_pull_output(),
                gpioe.pe8.into_push_pull_output(),
                gpioe.pe9.into_push_pull_output(),
                gpioe.pe10.into_push_pull_output(),
                gpioe.pe11.into_push_pull_output(),
                gpioe.pe12.into_push_pull_output(),
            ),
        },
        scan_timer: dp.TIM2.counter_hz(&mut rcc),
        watchdog,
        reset_cause,
    }
}

/// The crash handlers' first act: the safe code straight into the DAC's channel-1 data
/// register, read back. No driver, no lock, nothing that can fail or wait; harmless before
/// `setup` (a write to an unclocked peripheral is ignored, and the read-back then says 0).
pub fn zero_actuator_register(cause: &'static str) -> SafeStop {
    let safe_code = tactile_firmware::BOARD.actuator.zero_code().0;
    // SAFETY: DHR12R1 is channel 1's right-aligned 12-bit data register; with the trigger off
    // (as `setup` leaves it) the output follows one APB1 clock later. Nothing else runs after a
    // crash, so taking the register from its owner here races with no one.
    let dac_code = unsafe {
        let dac = &*pac::DAC::ptr();
        dac.dhr12r1().write(|w| w.bits(u32::from(safe_code)));
        dac.dhr12r1().read().bits() as u16
    };
    SafeStop {
        cause,
        board: true,
        dac_code,
        safe_code,
    }
}

impl ControlBoard {
    /// Zero volts into the current amplifier (mid-scale code through the level shifter).
    pub fn zero_actuator(&mut self) {
        let code = tactile_firmware::BOARD.actuator.zero_code();
        self.dac.set_value(code.0);
    }
}

/// A board's pins with the converter borrowed for one task body.
pub struct WithAdc<'a, B> {
    pub adc: &'a mut Converter,
    pub board: &'a mut B,
}

impl ControlIo for WithAdc<'_, ControlBoard> {
    fn read_gauge(&mut self) -> [AdcCode; SAMPLES_PER_TICK] {
        // Eight conversions back to back (15 cycles sampling + 12 bits at 21 MHz: 1.3 µs
        // each), at the start of the tick.
        let mut codes = [AdcCode(0); SAMPLES_PER_TICK];
        for c in codes.iter_mut() {
            *c = AdcCode(self.adc.convert(&self.board.gauge, SampleTime::Cycles_15));
        }
        codes
    }
    fn read_probe_channel(&mut self) -> AdcCode {
        AdcCode(self.adc.convert(&self.board.probe, SampleTime::Cycles_84))
    }
    fn write_actuator(&mut self, code: AdcCode) {
        self.board.dac.set_value(code.0);
    }
}

impl ScanIo for WithAdc<'_, ScanBoard> {
    fn select_taxel(&mut self, taxel: TaxelId) {
        self.board.select(taxel);
    }
    fn read_taxel(&mut self) -> AdcCode {
        AdcCode(self.adc.convert(&self.board.taxel, SampleTime::Cycles_84))
    }
}

impl ScanBoard {
    /// Drives the multiplexer address lines for `taxel`.
    pub fn select(&mut self, taxel: TaxelId) {
        let row = taxel.row() as u32 & ADDRESS_MASK;
        let col = taxel.col() as u32 & ADDRESS_MASK;
        let set = (row << ROW_SHIFT) | (col << COL_SHIFT);
        let clear = ((ADDRESS_MASK << ROW_SHIFT) | (ADDRESS_MASK << COL_SHIFT)) & !set;
        // All six address lines change in one BSRR write, so the multiplexer never sees a
        // mixed address. The pins are owned by this struct (configured as outputs in
        // `setup`); BSRR writes are atomic and touch no other line.
        // SAFETY: a write-only set/reset register; only PE7–PE12, which this struct owns.
        unsafe {
            (*pac::GPIOE::ptr())
                .bsrr()
                .write(|w| w.bits(set | (clear << 16)))
        };
    }

    /// Start-up calibration, probe lifted: each taxel's at-rest output, the mean of `frames`
    /// readings after a full dwell. The trims are the memo's element 4,2 values for every
    /// taxel until each is measured (`TaxelCalibration::amplifier`).
    pub fn rest_calibration(
        &mut self,
        adc: &mut Converter,
        frames: u32,
    ) -> [TaxelCalibration; TAXELS] {
        let config = tactile_firmware::BOARD;
        let dwell_cycles = (config.scan.dwell_s * CORE_HZ as f32) as u32;
        let mut sums = [0.0f32; TAXELS];
        for _ in 0..frames.max(1) {
            for (i, sum) in sums.iter_mut().enumerate() {
                let mut io = WithAdc { adc, board: self };
                io.select_taxel(TaxelId::from_index(i));
                cortex_m::asm::delay(dwell_cycles);
                *sum += config.taxel_adc.volts(io.read_taxel());
            }
        }
        sums.map(|sum| TaxelCalibration {
            amplifier: ReadoutAmplifier::MEMO_ELEMENT_4_2,
            rest_output_v: sum / frames.max(1) as f32,
            gain: 1.0,
        })
    }
}
