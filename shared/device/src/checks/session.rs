//! The commander: the handshake before `Arm` and `SetMode`, the schema fingerprint, which
//! requests feed the command timeout, and the pressures mode's service interlock.

use super::*;

fn as_session(
    d: &mut Device,
    session: SessionId,
    body: RequestBody,
) -> Result<ReplyData, ErrorCode> {
    d.handle(&Request {
        id: 78,
        body,
        session,
    })
    .result
}

fn hello(d: &mut Device, schema_fingerprint: u32) -> Result<SessionId, ErrorCode> {
    match as_session(
        d,
        NO_SESSION,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint,
        },
    ) {
        Ok(ReplyData::Hello(info)) => Ok(info.session),
        Ok(_) => Err(ErrorCode::Malformed),
        Err(e) => Err(e),
    }
}

/// Periods until the command timeout latches (at most `n`), with `each_50` run every
/// 50 periods.
fn periods_to_timeout(d: &mut Device, n: u32, mut each_50: impl FnMut(&mut Device)) -> u32 {
    for k in 0..n {
        if k % 50 == 49 {
            each_50(d);
        }
        let out = d.step(raw(HOME, k), StepTiming::default());
        if out
            .fault_event
            .map(|e| e.bits & Faults::COMMAND_TIMEOUT.0 != 0)
            == Some(true)
        {
            return k + 1;
        }
    }
    n
}

const JOINT: Mode = Mode::Joint {
    alpha_rad: [0.0, 0.0],
    torque_nm: [0.0, 0.0],
    stiffness_nm_per_rad: [20.0, 20.0],
};

/// A token kept from before a reset is no session after it, however many handshakes the
/// new boot has answered; a guess is no session either. Each boot draws its own nonce.
pub fn a_session_does_not_survive_a_reboot() -> CheckResult {
    let boot = |nonce: u32| {
        let mut d = Device::new(
            RobotParams::thesis(),
            SafetyConfig::default_1khz(),
            DeviceOptions {
                boot_nonce: nonce,
                ..OPTIONS
            },
        );
        steps(&mut d, 1, 0);
        d
    };
    let mut before = boot(0x9e37_79b9);
    let mut kept = [NO_SESSION; 5];
    for slot in kept.iter_mut() {
        *slot = hello(&mut before, SCHEMA_FINGERPRINT).map_err(|_| Failure {
            what: "a handshake before the reset",
            got: 0.0,
            expected: 1.0,
            tolerance: 0.0,
            index: 0,
        })?;
    }
    holds(
        "the tokens are not the count of handshakes",
        kept.iter().zip(1u32..).all(|(&t, n)| t != n),
    )?;
    let mut after = boot(0x7f4a_7c15);
    for k in 0..20 {
        let _ = hello(&mut after, SCHEMA_FINGERPRINT);
        as_session(&mut after, NO_SESSION, RequestBody::Home).ok();
        for &token in &kept {
            holds(
                "a token from before the reset cannot arm",
                as_session(&mut after, token, RequestBody::Arm) == Err(ErrorCode::NoSession),
            )?;
        }
        // nor a guess at the count of handshakes
        holds(
            "a count is no token",
            as_session(&mut after, k + 1, RequestBody::Arm) == Err(ErrorCode::NoSession),
        )?;
    }
    let own = hello(&mut after, SCHEMA_FINGERPRINT).unwrap_or(NO_SESSION);
    holds(
        "the new boot's own token arms",
        as_session(&mut after, own, RequestBody::Arm) == Ok(ReplyData::Done),
    )
}

pub fn arm_and_set_mode_need_a_session_of_this_schema() -> CheckResult {
    let mut d = Device::new(RobotParams::thesis(), SafetyConfig::default_1khz(), OPTIONS);
    steps(&mut d, 1, 0);
    holds(
        "home without a session",
        as_session(&mut d, NO_SESSION, RequestBody::Home) == Ok(ReplyData::Done),
    )?;
    for session in [NO_SESSION, 1, 7] {
        holds(
            "arm without a handshake",
            as_session(&mut d, session, RequestBody::Arm) == Err(ErrorCode::NoSession),
        )?;
        holds(
            "mode without a handshake",
            as_session(&mut d, session, RequestBody::SetMode(JOINT.into()))
                == Err(ErrorCode::NoSession),
        )?;
    }
    holds(
        "another schema refused",
        hello(&mut d, SCHEMA_FINGERPRINT ^ 1) == Err(ErrorCode::SchemaMismatch),
    )?;
    holds(
        "a mismatched host cannot arm",
        as_session(&mut d, 1, RequestBody::Arm) == Err(ErrorCode::NoSession),
    )?;
    holds("still disarmed", d.controller().state() == State::Disarmed)?;
    let s = hello(&mut d, SCHEMA_FINGERPRINT);
    holds("the first handshake's session", s == Ok(1))?;
    holds(
        "arm after the handshake",
        as_session(&mut d, 1, RequestBody::Arm) == Ok(ReplyData::Done),
    )?;
    holds("the commander", d.commander() == 1)
}

/// `GetStatus`, another session's keep-alive and configuration reads keep nothing alive:
/// the armed device times out as if it heard nothing.
pub fn only_the_commander_feeds_the_command_timeout() -> CheckResult {
    let mut d = armed_device()?;
    let watcher = hello(&mut d, SCHEMA_FINGERPRINT).unwrap_or(NO_SESSION);
    let mut refusals_ok = true;
    let at = periods_to_timeout(&mut d, 1000, |d| {
        let _ = as_session(d, SESSION, RequestBody::GetStatus);
        let _ = as_session(d, watcher, RequestBody::GetConfig(ConfigSection::Limits));
        refusals_ok &=
            as_session(d, watcher, RequestBody::Heartbeat) == Err(ErrorCode::NotCommander);
        refusals_ok &=
            as_session(d, NO_SESSION, RequestBody::Heartbeat) == Err(ErrorCode::NotCommander);
    });
    holds("others' keep-alives refused", refusals_ok)?;
    near("timeout after 100 ms", at as f32, 100.0, 1.0)?;
    holds("faulted", d.controller().state() == State::Faulted)?;

    // the commander's keep-alive holds it for as long as it talks
    let mut d = armed_device()?;
    let at = periods_to_timeout(&mut d, 1000, |d| {
        let _ = as_session(d, SESSION, RequestBody::Heartbeat);
    });
    holds("alive while the commander talks", at == 1000)?;
    holds("armed", d.controller().state() == State::Armed)?;
    let at = periods_to_timeout(&mut d, 300, |_| {});
    near("then silence times out", at as f32, 100.0, 1.0)
}

/// Setting the mode makes a session the commander; the one before it no longer feeds.
pub fn setting_the_mode_takes_the_command() -> CheckResult {
    let mut d = armed_device()?;
    let second = hello(&mut d, SCHEMA_FINGERPRINT).unwrap_or(NO_SESSION);
    holds(
        "mode from another host's session",
        as_session(&mut d, second, RequestBody::SetMode(JOINT.into())) == Ok(ReplyData::Done),
    )?;
    holds("the second commands", d.commander() == second)?;
    holds(
        "the first's keep-alive refused",
        as_session(&mut d, SESSION, RequestBody::Heartbeat) == Err(ErrorCode::NotCommander),
    )?;
    holds(
        "the limits are the commander's while armed",
        as_session(
            &mut d,
            SESSION,
            RequestBody::SetConfig(Config::Limits(SafetyConfig::default_1khz().into())),
        ) == Err(ErrorCode::NotCommander),
    )?;
    // the first takes it back explicitly, mode unchanged
    holds(
        "taken back",
        as_session(&mut d, SESSION, RequestBody::TakeCommand) == Ok(ReplyData::Done)
            && d.commander() == SESSION
            && d.controller().mode() == JOINT,
    )?;
    holds(
        "the second's keep-alive refused",
        as_session(&mut d, second, RequestBody::Heartbeat) == Err(ErrorCode::NotCommander),
    )?;
    // anyone may disarm
    done(&mut d, RequestBody::Disarm)?;
    holds("no commander", d.commander() == NO_SESSION)?;
    refused(&mut d, RequestBody::TakeCommand, ErrorCode::WrongState)
}

pub fn pressures_mode_needs_the_service_interlock() -> CheckResult {
    let pressures: pam_protocol::wire::Mode = Mode::Pressures {
        pressure_bar: [1.0, 1.0, 1.0, 1.0],
    }
    .into();
    let mut d = armed_device()?;
    refused(
        &mut d,
        RequestBody::SetMode(pressures),
        ErrorCode::ServiceModeOff,
    )?;
    holds("still idle", d.controller().mode() == Mode::Idle)?;
    done(&mut d, RequestBody::SetMode(JOINT.into()))?;
    // not while armed in another mode
    refused(
        &mut d,
        RequestBody::SetServiceMode { enabled: true },
        ErrorCode::WrongState,
    )?;
    done(&mut d, RequestBody::Disarm)?;
    holds("the status shows it off", !status(&mut d)?.service_mode)?;
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    holds("the status shows it on", status(&mut d)?.service_mode)?;
    done(&mut d, RequestBody::Arm)?;
    done(&mut d, RequestBody::SetMode(pressures))?;
    // off leaves the pressures mode at once
    done(&mut d, RequestBody::SetServiceMode { enabled: false })?;
    holds("idle", d.controller().mode() == Mode::Idle)?;
    refused(
        &mut d,
        RequestBody::SetMode(pressures),
        ErrorCode::ServiceModeOff,
    )?;
    // a disarm ends it
    done(&mut d, RequestBody::SetServiceMode { enabled: true })?;
    done(&mut d, RequestBody::Disarm)?;
    holds(
        "off after a disarm",
        !d.service_mode() && !status(&mut d)?.service_mode,
    )
}
