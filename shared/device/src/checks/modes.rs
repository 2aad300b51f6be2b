//! Mode requests: range checks, and each mode reaching the output currents.

use super::*;

pub fn out_of_range_mode_is_refused_and_nothing_changes() -> CheckResult {
    let mut d = armed_device()?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    let good = Mode::Pressures {
        pressure_bar: [1.0, 2.0, 3.0, 2.5],
    };
    done(&mut d, RequestBody::SetMode(good.into()))?;
    for bad in [
        Mode::Pressures {
            pressure_bar: [1.0, 2.0, 5.5, 2.5],
        },
        Mode::Pressures {
            pressure_bar: [f32::NAN, 2.0, 3.0, 2.5],
        },
        Mode::Joint {
            alpha_rad: [1.0, 0.0],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
        },
        Mode::Force {
            force_n: [1000.0, 0.0],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        },
    ] {
        refused(
            &mut d,
            RequestBody::SetMode(bad.into()),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("mode unchanged", d.controller().mode() == good)?;
    holds("still armed", d.controller().state() == State::Armed)
}

pub fn each_mode_reaches_the_outputs() -> CheckResult {
    let mut d = armed_device()?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [1.0, 2.0, 3.0, 2.5],
            }
            .into(),
        ),
    )?;
    // the tensioning ramp (1 s) ends on the pressures
    let out = steps_alive(&mut d, 1100, 1);
    let t = out.telemetry.unwrap_or_else(unreachable_telemetry);
    near("channel 3 pressure", t.pressure_cmd_bar[2], 3.0, 1e-5)?;
    holds(
        "pressures mode",
        t.mode == ModeKind::Pressures && t.force_ref_n.is_none(),
    )?;
    let ip = &d.controller().model().params.ip;
    near(
        "channel 3 current",
        out.current_ma[2],
        (3.0 - ip.offset_bar) / ip.gain_bar_per_ma,
        1e-3,
    )?;

    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Joint {
                alpha_rad: [0.0, 0.0],
                torque_nm: [0.0, 0.0],
                stiffness_nm_per_rad: [60.0, 27.0],
            }
            .into(),
        ),
    )?;
    let t = steps_alive(&mut d, 200, 1200)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds(
        "joint mode",
        t.mode == ModeKind::Joint && t.state == State::Armed,
    )?;
    let p = t.pressure_cmd_bar;
    // zero torque at the neutral pose: both muscles of a pair at the same pressure
    near("joint 1 pair balanced", p[0], p[1], 1e-3)?;
    near("joint 2 pair balanced", p[2], p[3], 1e-3)?;

    let force = [9.1, -4.0];
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Force {
                force_n: force,
                stiffness_nm_per_rad: [60.0, 27.0],
                feed_forward: true,
            }
            .into(),
        ),
    )?;
    let t = steps_alive(&mut d, 200, 1500)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds(
        "force mode with feed-forward",
        t.mode == ModeKind::ForceFeedForward,
    )?;
    holds("force reference reported", t.force_ref_n == Some(force))?;
    holds("no fault", t.faults == 0 && t.state == State::Armed)
}
