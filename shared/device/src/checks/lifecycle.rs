//! Power-on state, the handshake, arming and homing.

use super::*;

pub fn boots_disarmed_unhomed_and_vented() -> CheckResult {
    let mut d = device();
    let out = steps(&mut d, 1, 0);
    holds("vent currents", out.current_ma.iter().all(|&i| i == 4.0))?;
    let t = out.telemetry.ok_or(Failure {
        what: "telemetry at boot",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    holds("seq starts at 0", t.seq == 0)?;
    holds(
        "disarmed",
        t.state == State::Disarmed && t.mode == ModeKind::Idle,
    )?;
    let s = status(&mut d)?;
    holds(
        "not homed",
        !s.homed && s.period_us == 1000 && s.telemetry_divider == 1,
    )
}

pub fn hello_answers_versions_and_refuses_another_protocol() -> CheckResult {
    let mut d = device();
    match request(
        &mut d,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
    ) {
        Ok(ReplyData::Hello(info)) => {
            holds(
                "protocol version",
                info.protocol_version == PROTOCOL_VERSION,
            )?;
            holds(
                "firmware version",
                info.firmware_version == OPTIONS.firmware_version,
            )?;
            holds("period", info.period_us == 1000)?;
            holds(
                "params hash",
                info.params_hash == pam_protocol::params_hash(&RobotParams::thesis()),
            )?;
            holds("a new session", info.session == SESSION + 1)?;
        }
        _ => holds("hello answered", false)?,
    }
    refused(
        &mut d,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION + 1,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
        ErrorCode::UnsupportedVersion,
    )
}

pub fn arm_needs_homing_and_disarm_vents() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    refused(&mut d, RequestBody::Arm, ErrorCode::NotHomed)?;
    holds("still disarmed", d.controller().state() == State::Disarmed)?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [2.0; 4],
            }
            .into(),
        ),
    )?;
    // the tensioning ramp (1 s) first
    let out = steps_alive(&mut d, 1100, 1);
    holds("pressurised", out.current_ma.iter().all(|&i| i > 9.0))?;
    done(&mut d, RequestBody::Disarm)?;
    let out = steps(&mut d, 1, 1110);
    holds("vented at once", out.current_ma.iter().all(|&i| i == 4.0))
}

/// A board whose output stage can drive current while the MCU is in reset (the first
/// revision, or a board that does not identify itself: the firmware reads its straps at
/// boot) never arms: its `SELF_CHECK` cannot be cleared, so not even one period is left to
/// arm in, and the host sees why.
pub fn a_board_unsafe_in_reset_never_arms() -> CheckResult {
    let mut d = device();
    d.set_board_health(BoardHealth {
        board_checks: pam_protocol::BOARD_CHECK_OUTPUT_STAGE,
        ..d.board_health()
    });
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    refused(
        &mut d,
        RequestBody::ClearFaults,
        ErrorCode::FaultStillPresent,
    )?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    let out = steps(&mut d, 1, 1);
    holds("vented", out.current_ma.iter().all(|&i| i == 4.0))?;
    let s = status(&mut d)?;
    holds(
        "the status says why",
        s.board_checks == pam_protocol::BOARD_CHECK_OUTPUT_STAGE
            && s.faults & Faults::SELF_CHECK.0 != 0
            && d.controller().state() != State::Armed,
    )
}

pub fn home_zeroes_the_angle_and_is_refused_while_armed() -> CheckResult {
    let mut d = device();
    let t = steps(&mut d, 1, 0)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds("boot position is the origin", t.alpha_rad == [0.0, 0.0])?;
    // move slowly (10 counts per ms = 7.9 rad/s, below the encoder-jump speed)
    let mut t = None;
    for k in 1..=8 {
        t = d
            .step(
                raw([HOME[0] + 10 * k, HOME[1] - 5 * k], k),
                StepTiming::default(),
            )
            .telemetry;
    }
    let moved = [HOME[0] + 80, HOME[1] - 40];
    let a = t.map(|t| t.alpha_rad).unwrap_or([9.0; 2]);
    let per_count = 2.0 * core::f32::consts::PI / 8000.0;
    near(
        "alpha1 before homing",
        a[0],
        (moved[0] - HOME[0]) as f32 * per_count,
        1e-6,
    )?;
    done(&mut d, RequestBody::Home)?;
    let t = d.step(raw(moved, 9), StepTiming::default()).telemetry;
    holds(
        "homed position reads zero",
        t.map(|t| t.alpha_rad) == Some([0.0, 0.0]),
    )?;
    holds(
        "homing is no encoder jump",
        d.controller().faults().is_none(),
    )?;
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Home, ErrorCode::WrongState)
}

/// Once homed, the counts run on from boot: a re-home far from the zero in use is a wrong
/// pose (or lost counts) and is refused; one near it corrects the zero.
pub fn rehome_far_from_the_zero_is_refused() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    // 0.2 rad on joint 1 (255 counts at 8000 counts/rev), moved slowly
    let mut at = HOME;
    for k in 1..=51 {
        at = [HOME[0] + 5 * k, HOME[1]];
        d.step(raw(at, k), StepTiming::default());
    }
    refused(&mut d, RequestBody::Home, ErrorCode::Implausible)?;
    holds(
        "zero unchanged",
        d.step(raw(at, 52), StepTiming::default())
            .telemetry
            .map(|t| t.alpha_rad[0] > 0.19)
            == Some(true),
    )?;
    // back to within 0.1 rad of the zero: the re-home is taken
    for k in 1..=30 {
        at = [at[0] - 5, HOME[1]];
        d.step(raw(at, 52 + k), StepTiming::default());
    }
    done(&mut d, RequestBody::Home)
}

/// A first home cannot be judged when it is asked (the vented arm rests anywhere): it is
/// taken, and judged at the first rest with the muscles tensioned. Homed with joint 2 0.3
/// rad (17°) from the neutral pose, the arm put back there by hand, armed in the pressures
/// mode at 2.5 bar (whose equilibrium is the neutral pose) with a free handle: the rest lies
/// 0.3 rad from it, and the home is refused: a `STATIC_IMBALANCE` fault event, vented,
/// `homed` false, `Arm` answers `NotHomed`. Cleared, a home at the neutral pose is taken
/// (the refused zero bounds no re-home) and confirmed by the same rest.
pub fn a_first_home_far_from_the_pressures_equilibrium_is_refused() -> CheckResult {
    let mut d = device();
    let mut k = 0;
    let mut to = |d: &mut Device, counts: [u32; 2]| {
        k += 1;
        d.step(raw(counts, k), StepTiming::default())
    };
    to(&mut d, HOME);
    // 382 counts of 8000 a turn: 0.3 rad, moved slowly both ways
    for n in 1..=76 {
        to(&mut d, [HOME[0], HOME[1] + 5 * n]);
    }
    to(&mut d, [HOME[0], HOME[1] + 382]);
    done(&mut d, RequestBody::Home)?;
    for n in (0..76).rev() {
        to(&mut d, [HOME[0], HOME[1] + 5 * n]);
    }
    let pressurised = |d: &mut Device| -> CheckResult {
        done(d, RequestBody::SetServiceMode { enabled: true })?;
        done(d, RequestBody::Arm)?;
        done(
            d,
            RequestBody::SetMode(
                Mode::Pressures {
                    pressure_bar: [2.5; 4],
                }
                .into(),
            ),
        )
    };
    pressurised(&mut d)?;
    let mut event = None;
    for n in 0..5000 {
        if n % 10 == 0 {
            d.handle(&Request {
                id: 1,
                body: RequestBody::Heartbeat,
                session: SESSION,
            });
        }
        let out = to(&mut d, HOME);
        event = event.or(out.fault_event);
    }
    holds(
        "refused: a STATIC_IMBALANCE fault event",
        event.map(|e| e.bits) == Some(Faults::STATIC_IMBALANCE.0),
    )?;
    holds("vented", to(&mut d, HOME).current_ma == [4.0; 4])?;
    holds("no longer homed", !status(&mut d)?.homed)?;
    done(&mut d, RequestBody::ClearFaults)?;
    refused(&mut d, RequestBody::Arm, ErrorCode::NotHomed)?;
    done(&mut d, RequestBody::Home)?;
    pressurised(&mut d)?;
    let out = steps_alive(&mut d, 5000, k + 1);
    holds(
        "the right home: no fault, confirmed",
        out.fault_event.is_none()
            && d.controller().state() == State::Armed
            && !d.controller().home_check().pending()
            && status(&mut d)?.homed,
    )
}
