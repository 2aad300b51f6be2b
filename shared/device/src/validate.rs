//! What the device accepts as configuration. The host validates nothing that matters:
//! these checks are the ones that protect the patient.

use crate::ABSOLUTE_MAX_PRESSURE_BAR;
use pam_control::{MAX_LOOP_CURRENT_MA, VENT_CURRENT_MA};
use pam_model::RobotParams;
use pam_protocol::{Calibration, ErrorCode};

fn all_finite(values: &[f32]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn in_range(v: f32, lo: f32, hi: f32) -> bool {
    v.is_finite() && v >= lo && v <= hi
}

fn ok_if(ok: bool) -> Result<(), ErrorCode> {
    if ok {
        Ok(())
    } else {
        Err(ErrorCode::OutOfRange)
    }
}

pub fn robot_params(p: &RobotParams<f32>) -> Result<(), ErrorCode> {
    p.validate().map_err(|_| ErrorCode::OutOfRange)?;
    for j in &p.joints {
        ok_if(all_finite(&[
            j.segment_length_m,
            j.pulley_radius_m,
            j.alpha_min_rad,
            j.alpha_max_rad,
            j.initial_shortening_m,
            j.muscle_rest_length_m,
            j.pretension_pressure_bar,
            j.segment.mass_kg,
            j.segment.com_distance_m,
            j.segment.inertia_com_kg_m2,
        ]))?;
        // joint ranges beyond ±90° are not this robot
        ok_if(in_range(j.alpha_min_rad, -1.6, 1.6) && in_range(j.alpha_max_rad, -1.6, 1.6))?;
    }
    ok_if(all_finite(&p.muscle.pressure_n_per_pa) && all_finite(&p.muscle.passive_n))?;
    let ip = &p.ip;
    ok_if(all_finite(&[
        ip.gain_bar_per_ma,
        ip.offset_bar,
        ip.output_min_bar,
        ip.output_max_bar,
        ip.natural_freq_rad_s,
        ip.damping_ratio,
    ]))?;
    // The pressure law starts at the converters' floor, exactly: the law saturates a
    // command below its first current up to it, so a floor above 4 mA would turn a low
    // pressure command into a higher one (12 mA is ≈ 2.3 bar), and one below would leave
    // the loop range. The safe state does not depend on it: it is the fixed VENT_CURRENT_MA.
    ok_if(
        ip.current_min_ma == VENT_CURRENT_MA
            && in_range(ip.current_max_ma, VENT_CURRENT_MA, MAX_LOOP_CURRENT_MA)
            && ip.current_min_ma < ip.current_max_ma,
    )?;
    ok_if(
        in_range(p.pressure.min_bar, 0.0, ABSOLUTE_MAX_PRESSURE_BAR)
            && in_range(p.pressure.max_bar, 0.0, ABSOLUTE_MAX_PRESSURE_BAR)
            && in_range(ip.output_min_bar, 0.0, ABSOLUTE_MAX_PRESSURE_BAR),
    )?;
    load_cell(&p.load_cell)?;
    ok_if(all_finite(&[
        p.gain_plane.coeffs[0][0],
        p.gain_plane.coeffs[0][1],
        p.gain_plane.coeffs[0][2],
        p.gain_plane.coeffs[1][0],
        p.gain_plane.coeffs[1][1],
        p.gain_plane.coeffs[1][2],
        p.gain_plane.min_gain,
    ]))
}

fn load_cell(c: &pam_model::params::LoadCell<f32>) -> Result<(), ErrorCode> {
    for ch in 0..2 {
        let g = c.gain_n_per_v[ch];
        ok_if(g.is_finite() && g != 0.0 && g.abs() <= 10_000.0)?;
        ok_if(in_range(c.offset_v[ch], -10.0, 10.0))?;
    }
    ok_if(in_range(c.rated_force_n, 1.0, 10_000.0))
}

/// Largest encoder zero, rad (≈ 8.6°): the homing mark is near the neutral pose; a larger
/// zero is a wrong pose at homing, not a mark to correct.
pub const MAX_ENCODER_ZERO_RAD: f32 = 0.15;

pub fn calibration(c: &Calibration) -> Result<(), ErrorCode> {
    for e in &c.encoder {
        ok_if((16..=1 << 24).contains(&e.counts_per_rev) && (e.sign == 1 || e.sign == -1))?;
        ok_if(in_range(
            e.zero_rad,
            -MAX_ENCODER_ZERO_RAD,
            MAX_ENCODER_ZERO_RAD,
        ))?;
    }
    ok_if(crate::channel_map::is_permutation(c.output_of_channel))?;
    load_cell(&c.load_cell.into())?;
    for o in &c.output {
        ok_if(in_range(o.gain, 0.5, 1.5) && in_range(o.offset_ma, -2.0, 2.0))?;
    }
    Ok(())
}
