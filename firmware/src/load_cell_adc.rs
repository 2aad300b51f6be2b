//! Load-cell ADC driver: the X and Z channels sampled at the same instant, as the NI 9215
//! of the original rig did.
//!
//! # Why dual injected-simultaneous mode
//!
//! One ADC converting X then Z would sample Z one conversion later: 47.5 + 12.5 = 60 ADC
//! clocks = 1.41 µs at 42.5 MHz. That would be harmless for forces of a few Hz, but the
//! brief asks for the same instant and the G474 offers it for free: ADC1 (master) and ADC2
//! (slave) in *injected simultaneous* mode start their sample phases on the same ADC clock
//! edge when the master is triggered. The skew is zero by design; the only mismatch left is
//! the two sample-and-hold circuits' aperture, well under one ADC clock (23.5 ns). With the
//! same sample time on both, both conversions also end together.
//!
//! Injected rather than regular: the injected group has its own data registers (JDR1) per
//! ADC, so no DMA and no ordering of a shared data register is needed, and the regular
//! group stays free for slow housekeeping (VREFINT, temperature) later.
//!
//! Triggering: by software, at the start of each control step. The conversion (1.41 µs) is
//! waited for by polling, with a bound, so the step stays deterministic. The time-stamp
//! jitter of the sample is then that of the control task's wake-up, which the loop measures
//! (DWT) and reports.
//!
//! The HAL does the power-up, the calibration (single-ended and differential) and the
//! enable; the dual-mode injected setup is done here on the registers (RM0440 §21.4.32),
//! because embassy-stm32 0.6 has no software-triggered dual injected API.
//!
//! # Dual mode read-back
//!
//! RM0440 allows ADC12_CCR.DUAL to be written only while the ADCs are disabled, and the
//! HAL writes it after enabling ADC1. Whether the write took is read back at boot
//! ([`LoadCellAdc::dual_mode_ok`]); if not, the board check `BOARD_CHECK_ADC_DUAL` keeps
//! `SELF_CHECK` raised and the robot cannot arm (without dual mode the slave never converts
//! and every read would time out anyway, as NON_FINITE).
//!
//! # VDDA
//!
//! The ADC's full scale is VDDA, and the front end's reading scales with it
//! (`pam_firmware_logic::vdda`). Every [`VREFINT_PERIODS`] the regular group of ADC1 (free
//! in this dual mode) converts VREFINT, started after one period's injected read and
//! collected at the next (no waiting in the loop); the readings are scaled by the measured
//! VDDA while it is within 3.3 V ± 5 %, by the nominal 3.3 V otherwise.

use embassy_stm32::adc::{Adc, AdcChannel, AdcConfig, AnyAdcChannel, Dual};
use embassy_stm32::pac::adc::vals::{Exten, SampleTime};
use pam_firmware_logic::vdda;

use crate::board::{self, LoadCellAdcMaster, LoadCellAdcSlave};

/// One simultaneous sample of both channels, in volts at the amplifier's outputs (the
/// input of eq. 2.1), with the raw ADC counts kept for diagnostics.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub struct LoadCellSample {
    /// Sensor X and Z channel voltages at the amplifier outputs, V.
    pub volts: [f32; 2],
    pub raw_counts: [u16; 2],
    /// A channel read at either rail (`board::LOAD_CELL_FRONT_END`): the voltage is not
    /// trustworthy (front end or amplifier saturated).
    pub saturated: bool,
}

/// The conversion did not finish in time (ADC not clocked or not enabled).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct AdcTimeout;

pub struct LoadCellAdc {
    // Kept so the HAL keeps the ADCs powered and nobody else can claim them.
    _master: Adc<'static, LoadCellAdcMaster>,
    _slave: Adc<'static, LoadCellAdcSlave>,
    _x: AnyAdcChannel<'static, LoadCellAdcMaster>,
    _z: AnyAdcChannel<'static, LoadCellAdcSlave>,
    dual_mode_ok: bool,
    vrefint_cal: u16,
    /// The last VDDA measurement (`None`: none yet, or the calibration word is not one).
    vdda_v: Option<f32>,
    vrefint_started: bool,
    periods_to_vrefint: u16,
}

/// VDDA is measured every this many periods (10 Hz at 1 kHz).
pub const VREFINT_PERIODS: u16 = 100;
/// ADC1's channel for VREFINT (RM0440 §21.4.11).
const VREFINT_CHANNEL: u8 = 18;
/// Factory calibration: the VREFINT code at VDDA = 3.0 V (datasheet, "VREFINT_CAL").
const VREFINT_CAL_ADDRESS: usize = 0x1FFF_75AA;

/// Polling bound: each ISR read is a few AHB cycles, so 2000 polls last far longer than
/// the 60-clock (1.41 µs) conversion, and at worst ~25 µs if the ADC is dead.
const POLL_LIMIT: u32 = 2_000;

impl LoadCellAdc {
    pub fn new(cell: board::LoadCell) -> Self {
        // Analogue mode on the pins (the HAL's channel setup does only that on the G4).
        let x: AnyAdcChannel<'static, LoadCellAdcMaster> = cell.x.degrade_adc();
        let z: AnyAdcChannel<'static, LoadCellAdcSlave> = cell.z.degrade_adc();

        let master = Adc::new(
            cell.adc_master,
            AdcConfig {
                dual_mode: Some(Dual::DUAL_J),
                ..Default::default()
            },
        );
        let slave = Adc::new(cell.adc_slave, AdcConfig::default());

        let m = board::LOAD_CELL_ADC_MASTER;
        let s = board::LOAD_CELL_ADC_SLAVE;
        for (adc, ch) in [
            (m, board::LOAD_CELL_X_ADC_CHANNEL),
            (s, board::LOAD_CELL_Z_ADC_CHANNEL),
        ] {
            // JSQR may only be written with no injected conversion going on (true after
            // the HAL's init). Queue disabled: the written sequence applies at once.
            adc.cfgr().modify(|w| w.set_jqdis(true));
            if ch <= 9 {
                adc.smpr()
                    .modify(|w| w.set_smp(ch as usize, board::LOAD_CELL_SAMPLE_TIME));
            } else {
                adc.smpr2()
                    .modify(|w| w.set_smp(ch as usize - 10, board::LOAD_CELL_SAMPLE_TIME));
            }
            adc.jsqr().write(|w| {
                w.set_jl(0); // one conversion
                w.set_jsq(0, ch);
                w.set_jexten(Exten::DISABLED); // software trigger (master's JADSTART)
            });
            adc.isr().write(|w| {
                w.set_jeos(true);
                w.set_jeoc(true);
            });
        }
        let common = board::LOAD_CELL_ADC_COMMON;
        let dual_mode_ok = common.ccr().read().dual() == Dual::DUAL_J;
        if !dual_mode_ok {
            defmt::error!("ADC12_CCR.DUAL did not take: dual injected mode off");
        }
        // VREFINT on ADC1's regular group: the datasheet's minimum sampling time is 4 µs,
        // 247.5 ADC clocks are 5.8 µs at 42.5 MHz
        common.ccr().modify(|w| w.set_vrefen(true));
        m.smpr2()
            .modify(|w| w.set_smp(VREFINT_CHANNEL as usize - 10, SampleTime::CYCLES247_5));
        m.sqr1().modify(|w| {
            w.set_l(0);
            w.set_sq(0, VREFINT_CHANNEL);
        });
        // SAFETY: a half-word of the system memory's engineering bytes, always readable.
        let vrefint_cal = unsafe { (VREFINT_CAL_ADDRESS as *const u16).read_volatile() };
        Self {
            _master: master,
            _slave: slave,
            _x: x,
            _z: z,
            dual_mode_ok,
            vrefint_cal,
            vdda_v: None,
            vrefint_started: false,
            periods_to_vrefint: 1,
        }
    }

    /// ADC1/ADC2 are in dual injected-simultaneous mode (read back at boot).
    pub fn dual_mode_ok(&self) -> bool {
        self.dual_mode_ok
    }

    /// The last VDDA measurement.
    pub fn vdda_v(&self) -> Option<f32> {
        self.vdda_v
    }

    /// Once per period, after [`Self::read`]: collects a VREFINT conversion started in the
    /// previous period, and starts one every [`VREFINT_PERIODS`]. Never waits.
    pub fn vdda_tick(&mut self) {
        let m = board::LOAD_CELL_ADC_MASTER;
        if self.vrefint_started {
            if m.isr().read().eoc() {
                // reading DR clears EOC
                let counts = m.dr().read().rdata() & board::ADC_FULL_SCALE_COUNTS;
                self.vdda_v = vdda::vdda_v(self.vrefint_cal, counts);
                self.vrefint_started = false;
            }
            // not done after a whole period: try again at the next
            return;
        }
        self.periods_to_vrefint = self.periods_to_vrefint.saturating_sub(1);
        if self.periods_to_vrefint == 0 {
            self.periods_to_vrefint = VREFINT_PERIODS;
            m.cr().modify(|w| w.set_adstart(true));
            self.vrefint_started = true;
        }
    }

    /// Starts one simultaneous conversion of both channels and waits for it (≈1.4 µs).
    pub fn read(&mut self) -> Result<LoadCellSample, AdcTimeout> {
        let m = board::LOAD_CELL_ADC_MASTER;
        let s = board::LOAD_CELL_ADC_SLAVE;
        for adc in [m, s] {
            adc.isr().write(|w| w.set_jeos(true));
        }
        // In dual mode the master's start bit starts both ADCs.
        m.cr().modify(|w| w.set_jadstart(true));

        let mut done = false;
        for _ in 0..POLL_LIMIT {
            let csr = board::LOAD_CELL_ADC_COMMON.csr().read();
            if csr.jeos_mst() && csr.jeos_slv() {
                done = true;
                break;
            }
        }
        if !done {
            return Err(AdcTimeout);
        }
        let raw_counts = [
            m.jdr(0).read().jdata() & board::ADC_FULL_SCALE_COUNTS,
            s.jdr(0).read().jdata() & board::ADC_FULL_SCALE_COUNTS,
        ];
        for adc in [m, s] {
            adc.isr().write(|w| {
                w.set_jeos(true);
                w.set_jeoc(true);
            });
        }
        let front_end = board::LOAD_CELL_FRONT_END;
        let vdda_v = vdda::for_scaling(self.vdda_v);
        Ok(LoadCellSample {
            volts: raw_counts.map(|r| front_end.input_volts_at(r, vdda_v)),
            saturated: raw_counts.iter().any(|&r| front_end.saturated(r)),
            raw_counts,
        })
    }
}
