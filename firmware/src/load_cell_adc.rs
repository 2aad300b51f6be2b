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

use embassy_stm32::adc::{Adc, AdcChannel, AdcConfig, AnyAdcChannel, Dual};
use embassy_stm32::pac::adc::vals::Exten;

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
}

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
        Self {
            _master: master,
            _slave: slave,
            _x: x,
            _z: z,
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
        Ok(LoadCellSample {
            volts: raw_counts.map(|r| front_end.input_volts(r)),
            saturated: raw_counts.iter().any(|&r| front_end.saturated(r)),
            raw_counts,
        })
    }
}
