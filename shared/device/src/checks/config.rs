//! Configuration: every section read back, invalid parameters, calibration and limits refused.

use super::*;

pub fn get_config_returns_every_section() -> CheckResult {
    let mut d = device();
    holds(
        "robot",
        config(&mut d, ConfigSection::Robot)? == Config::Robot(RobotParams::thesis().into()),
    )?;
    holds(
        "limits",
        config(&mut d, ConfigSection::Limits)?
            == Config::Limits(SafetyConfig::default_1khz().into()),
    )?;
    holds(
        "calibration",
        config(&mut d, ConfigSection::Calibration)? == Config::Calibration(d.calibration()),
    )
}

pub fn invalid_robot_parameters_are_refused_and_nothing_changes() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let before = config(&mut d, ConfigSection::Robot)?;
    let thesis = RobotParams::<f32>::thesis();
    let mut over_pressure = thesis;
    over_pressure.pressure.max_bar = 6.0;
    let mut nan = thesis;
    nan.muscle.passive_n[2] = f32::NAN;
    let mut bad_map = thesis;
    bad_map.joints[1].channel_of_muscle = [0, 1];
    let mut bad_cell = thesis;
    bad_cell.load_cell.gain_n_per_v[0] = 0.0;
    for p in [over_pressure, nan, bad_map, bad_cell] {
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Robot(p.into())),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("unchanged", config(&mut d, ConfigSection::Robot)? == before)?;
    let mut good = thesis;
    good.joints[0].pulley_radius_m = 0.072;
    done(&mut d, RequestBody::SetConfig(Config::Robot(good.into())))?;
    holds(
        "applied",
        d.controller().model().params.joints[0].pulley_radius_m == 0.072,
    )?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Robot(thesis.into())),
        ErrorCode::WrongState,
    )
}

pub fn invalid_calibration_is_refused_and_output_calibration_applies() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let good = d.calibration();
    let mut bad_sign = good;
    bad_sign.encoder[0].sign = 0;
    let mut bad_cpr = good;
    bad_cpr.encoder[1].counts_per_rev = 0;
    let mut bad_gain = good;
    bad_gain.output[2].gain = 3.0;
    let mut bad_offset = good;
    bad_offset.output[0].offset_ma = f32::INFINITY;
    for c in [bad_sign, bad_cpr, bad_gain, bad_offset] {
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Calibration(c)),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("unchanged", d.calibration() == good)?;
    let mut trimmed = good;
    trimmed.output[1] = OutputCalibration {
        gain: 1.0,
        offset_ma: 0.25,
    };
    trimmed.output[2] = OutputCalibration {
        gain: 0.9,
        offset_ma: 0.0,
    };
    done(&mut d, RequestBody::SetConfig(Config::Calibration(trimmed)))?;
    // the safe state is the fixed vent current: the trim never moves it
    let out = steps(&mut d, 1, 1);
    holds(
        "the vent is untrimmed",
        out.current_ma.iter().all(|&i| i == VENT_CURRENT_MA),
    )?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    done(&mut d, RequestBody::Arm)?;
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [2.0; 4],
            }
            .into(),
        ),
    )?;
    // through the tensioning ramp (1 s)
    let out = steps_alive(&mut d, 1100, 2);
    let t = out.telemetry.unwrap_or_else(unreachable_telemetry);
    holds("pressurised", t.current_ma.iter().all(|&i| i > 9.0))?;
    near(
        "offset trim",
        out.current_ma[1],
        t.current_ma[1] + 0.25,
        1e-5,
    )?;
    near("gain trim", out.current_ma[2], 0.9 * t.current_ma[2], 1e-5)?;
    done(&mut d, RequestBody::Disarm)?;
    let out = steps(&mut d, 1, 300);
    holds(
        "disarmed: the vent, untrimmed",
        out.current_ma.iter().all(|&i| i == VENT_CURRENT_MA),
    )
}

pub fn limits_are_validated_and_the_period_is_fixed_while_armed() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let mut slow = SafetyConfig::default_1khz();
    slow.period_s = 0.020;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(slow.into())),
        ErrorCode::OutOfRange,
    )?;
    let mut no_timeout = SafetyConfig::default_1khz();
    no_timeout.command_timeout_s = f32::NAN;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(no_timeout.into())),
        ErrorCode::OutOfRange,
    )?;
    for bad in [0, 101] {
        let mut overrun = SafetyConfig::default_1khz();
        overrun.overrun_fault_periods = bad;
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Limits(overrun.into())),
            ErrorCode::OutOfRange,
        )?;
    }
    holds(
        "overrun count unchanged",
        d.controller().safety().overrun_fault_periods == 3,
    )?;
    holds("period unchanged", d.period_us() == 1000)?;
    let mut two_ms = SafetyConfig::default_1khz();
    two_ms.period_s = 0.002;
    done(
        &mut d,
        RequestBody::SetConfig(Config::Limits(two_ms.into())),
    )?;
    holds("period 2 ms", d.period_us() == 2000)?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(SafetyConfig::default_1khz().into())),
        ErrorCode::WrongState,
    )?;
    let mut slower_slew = two_ms;
    slower_slew.slew_bar_per_s = 20.0;
    done(
        &mut d,
        RequestBody::SetConfig(Config::Limits(slower_slew.into())),
    )
}

/// The safe state is not a setting: a pressure law starting at 12 mA is refused, as are
/// limits beyond their ceilings; armed, limits only tighten.
pub fn no_configuration_moves_the_safe_state_or_loosens_a_limit() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let mut held = RobotParams::<f32>::thesis();
    held.ip.current_min_ma = 12.0;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Robot(held.into())),
        ErrorCode::OutOfRange,
    )?;
    let mut off = SafetyConfig::default_1khz();
    off.angle_margin_rad = f32::INFINITY;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(off.into())),
        ErrorCode::OutOfRange,
    )?;
    let mut crawl = SafetyConfig::default_1khz();
    crawl.timeout_ramp_bar_per_s = 1e-6;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(crawl.into())),
        ErrorCode::OutOfRange,
    )?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    let mut tighter = SafetyConfig::default_1khz();
    tighter.max_request_force_n = 40.0;
    done(
        &mut d,
        RequestBody::SetConfig(Config::Limits(tighter.into())),
    )?;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(SafetyConfig::default_1khz().into())),
        ErrorCode::WrongState,
    )?;
    holds(
        "the tighter limit in force",
        d.controller().safety().max_request_force_n == 40.0,
    )
}

pub fn the_channel_map_routes_the_outputs_and_must_be_a_permutation() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let good = d.calibration();
    holds(
        "stage c drives channel c by default",
        good.output_of_channel == pam_protocol::IDENTITY_CHANNEL_MAP,
    )?;
    for map in [[0, 0, 2, 3], [0, 1, 2, 4]] {
        let mut bad = good;
        bad.output_of_channel = map;
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Calibration(bad)),
            ErrorCode::OutOfRange,
        )?;
    }
    let mut bad_zero = good;
    bad_zero.encoder[1].zero_rad = 0.5;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Calibration(bad_zero)),
        ErrorCode::OutOfRange,
    )?;
    holds("unchanged", d.calibration() == good)?;
    let mut mapped = good;
    mapped.output_of_channel = [2, 1, 0, 3];
    mapped.output[0].offset_ma = 0.25;
    mapped.encoder[0].zero_rad = 0.05;
    done(&mut d, RequestBody::SetConfig(Config::Calibration(mapped)))?;
    holds("the map is kept", d.calibration() == mapped)?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    done(&mut d, RequestBody::Arm)?;
    let pressure_bar = [1.0, 2.0, 3.0, 2.5];
    done(
        &mut d,
        RequestBody::SetMode(Mode::Pressures { pressure_bar }.into()),
    )?;
    // through the tensioning ramp (1 s)
    let out = steps_alive(&mut d, 1100, 2);
    let t = out.telemetry.unwrap_or_else(unreachable_telemetry);
    // the telemetry keeps the channels' order; the stages get them through the map, each
    // with its own stage's trim
    near(
        "channel 1 leaves through stage 3",
        out.current_ma[2],
        t.current_ma[0],
        1e-4,
    )?;
    near(
        "channel 2 through stage 2",
        out.current_ma[1],
        t.current_ma[1],
        1e-4,
    )?;
    near(
        "channel 3 through stage 1, trimmed there",
        out.current_ma[0],
        t.current_ma[2] + 0.25,
        1e-4,
    )?;
    near(
        "channel 4 through stage 4",
        out.current_ma[3],
        t.current_ma[3],
        1e-4,
    )?;
    // homed at the mark: joint 1 reads minus its zero there
    near("the zero moves the angle", t.alpha_rad[0], -0.05, 1e-6)
}
