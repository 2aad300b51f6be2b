//! The sensor front end: encoder counts and calibration, load-cell volts to newtons, tare.

use super::*;

pub fn encoder_counts_survive_counter_wrap_both_ways() -> CheckResult {
    for bits in [16u8, 32] {
        let mut e = frontend::Encoders::new(bits, [EncoderCalibration::default(); 2]);
        let top = if bits == 16 { 0xFFFF } else { u32::MAX };
        let mut raw_counts = [top - 25, 30u32];
        e.update(raw_counts);
        // 60 periods of +7 counts on joint 1 (wraps forward), −3 on joint 2 (wraps back)
        for _ in 0..60 {
            raw_counts = [
                raw_counts[0].wrapping_add(7) & top,
                raw_counts[1].wrapping_sub(3) & top,
            ];
            e.update(raw_counts);
        }
        holds("no count lost on wrap", e.position_counts() == [420, -180])?;
    }
    Ok(())
}

pub fn encoder_calibration_sets_scale_and_sign() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    let mut cal = d.calibration();
    cal.encoder = [
        EncoderCalibration {
            counts_per_rev: 4000,
            sign: -1,
            zero_rad: 0.0,
        },
        EncoderCalibration {
            counts_per_rev: 10_000,
            sign: 1,
            zero_rad: 0.0,
        },
    ];
    done(&mut d, RequestBody::SetConfig(Config::Calibration(cal)))?;
    let t = d
        .step(
            raw([HOME[0] + 100, HOME[1] + 100], 1),
            StepTiming::default(),
        )
        .telemetry;
    let a = t.map(|t| t.alpha_rad).unwrap_or([9.0; 2]);
    let tau = 2.0 * core::f32::consts::PI;
    near(
        "joint 1: −100 counts of 4000",
        a[0],
        -100.0 * tau / 4000.0,
        1e-6,
    )?;
    near(
        "joint 2: 100 counts of 10000",
        a[1],
        100.0 * tau / 10_000.0,
        1e-6,
    )
}

pub fn loadcell_volts_become_user_frame_newtons_and_tare_zeroes_them() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    // a free handle's offset: 3.6 N and -3.3 N in the thesis calibration
    let volts = [0.32, -0.2];
    let r = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: volts,
    };
    let t = d.step(r, StepTiming::default()).telemetry;
    let f = t.map(|t| t.force_user_n).unwrap_or([f32::NAN; 2]);
    let model = d.controller().model();
    let sensor = [0.32 / 0.09, -0.2 / 0.06];
    let expected = Kinematics::sensor_to_user_at(&model.kinematics.trig([0.0, 0.0]), sensor);
    near("fx", f[0], expected[0], 1e-3)?;
    near("fy", f[1], expected[1], 1e-3)?;
    done(&mut d, RequestBody::Tare)?;
    let t = d.step(r, StepTiming::default()).telemetry;
    let f = t.map(|t| t.force_user_n).unwrap_or([f32::NAN; 2]);
    holds("tared force is zero", f == [0.0, 0.0])?;
    match config(&mut d, ConfigSection::Calibration)? {
        Config::Calibration(c) => {
            holds("tare is in the calibration", c.load_cell.offset_v == volts)?
        }
        _ => holds("calibration section", false)?,
    }
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Tare, ErrorCode::WrongState)
}

pub fn tare_before_any_sample_is_refused() -> CheckResult {
    let mut d = device();
    refused(&mut d, RequestBody::Tare, ErrorCode::WrongState)?;
    refused(&mut d, RequestBody::ClearFaults, ErrorCode::WrongState)
}

/// 30 N leaned on the handle at tare would become a commanded 30 N: refused, nothing
/// changed; the same tare with the handle free is taken.
pub fn tare_under_load_is_refused() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    let leaned = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: [30.0 * 0.09, 0.0],
    };
    d.step(leaned, StepTiming::default());
    refused(&mut d, RequestBody::Tare, ErrorCode::Implausible)?;
    holds(
        "offset unchanged",
        d.calibration().load_cell.offset_v == [0.0, 0.0],
    )?;
    // just beyond the bound on the other axis
    let beyond = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: [0.0, -(crate::calibration::TARE_MAX_FORCE_N + 0.5) * 0.06],
    };
    d.step(beyond, StepTiming::default());
    refused(&mut d, RequestBody::Tare, ErrorCode::Implausible)?;
    steps(&mut d, 1, 1);
    done(&mut d, RequestBody::Tare)
}

/// A negative load-cell gain reads a push as a pull: refused in the calibration and in the
/// robot parameters, nothing changed.
pub fn negative_load_cell_gain_is_refused() -> CheckResult {
    let mut d = device();
    let mut cal = d.calibration();
    cal.load_cell.gain_n_per_v[1] = -cal.load_cell.gain_n_per_v[1];
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Calibration(cal)),
        ErrorCode::Implausible,
    )?;
    let mut params = RobotParams::<f32>::thesis();
    params.load_cell.gain_n_per_v[0] = -params.load_cell.gain_n_per_v[0];
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Robot(params.into())),
        ErrorCode::Implausible,
    )?;
    holds(
        "gains unchanged",
        d.calibration().load_cell.gain_n_per_v[0] > 0.0
            && d.calibration().load_cell.gain_n_per_v[1] > 0.0,
    )?;
    // nor does a stored one boot
    let d = Device::new(params, SafetyConfig::default_1khz(), OPTIONS);
    holds(
        "boots with the thesis gains",
        d.calibration().load_cell.gain_n_per_v[0] > 0.0,
    )
}
