//! The link: telemetry rate and sequence, fault clearing,
//! corrupted frames, requests through the wire.

use super::*;
use pam_protocol::DeviceMessage;

pub fn telemetry_divider_and_sequence() -> CheckResult {
    let mut d = device();
    done(&mut d, RequestBody::SetTelemetry { divider: 3 })?;
    let mut sent = 0u32;
    for k in 0..30 {
        if let Some(t) = d.step(raw(HOME, k), StepTiming::default()).telemetry {
            holds("seq counts frames", t.seq == sent)?;
            holds("on the divider", k % 3 == 0)?;
            sent += 1;
        }
    }
    holds("one frame in three", sent == 10)?;
    done(&mut d, RequestBody::SetTelemetry { divider: 0 })?;
    holds("off", steps(&mut d, 10, 40).telemetry.is_none())?;
    let timing = StepTiming {
        time_us: 123_456,
        loop_exec_us: 17,
        loop_jitter_us: 3,
    };
    done(&mut d, RequestBody::SetTelemetry { divider: 1 })?;
    let t = d.step(raw(HOME, 0), timing).telemetry;
    holds(
        "timing carried",
        t.map(|t| (t.seq, t.time_us, t.loop_exec_us, t.loop_jitter_us))
            == Some((10, 123_456, 17, 3)),
    )
}

pub fn faults_clear_only_when_gone() -> CheckResult {
    let mut d = armed_device()?;
    d.raise(Faults::WATCHDOG_RESET);
    let out = steps(&mut d, 1, 1);
    holds(
        "fault event",
        out.fault_event.map(|e| e.code) == Some(7) && out.current_ma.iter().all(|&i| i == 4.0),
    )?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    done(&mut d, RequestBody::ClearFaults)?;
    holds(
        "cleared, disarmed",
        status(&mut d)?.faults == 0 && d.controller().state() == State::Disarmed,
    )?;
    // a saturated load cell that stays saturated cannot be cleared
    let sat = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: [20.0, 0.0],
    };
    let ev = d.step(sat, StepTiming::default()).fault_event;
    holds("saturation event", ev.map(|e| e.code) == Some(4))?;
    refused(
        &mut d,
        RequestBody::ClearFaults,
        ErrorCode::FaultStillPresent,
    )?;
    steps(&mut d, 1, 2);
    done(&mut d, RequestBody::ClearFaults)
}

pub fn corrupted_frames_get_a_malformed_reply() -> CheckResult {
    let mut d = device();
    let r = d.handle_frame(Err(DecodeError::Crc));
    holds(
        "unknown id",
        r.id == UNKNOWN_REQUEST_ID && r.result == Err(ErrorCode::Malformed),
    )?;
    let r = d.handle_frame(Err(DecodeError::Message {
        leading_u16: Some(42),
    }));
    holds(
        "id echoed",
        r.id == 42 && r.result == Err(ErrorCode::Malformed),
    )?;
    let r = d.handle_frame(Ok(Request {
        id: 5,
        body: RequestBody::Heartbeat,
        session: SESSION,
    }));
    holds(
        "good frame handled",
        r.id == 5 && r.result == Ok(ReplyData::Done),
    )
}

pub fn requests_survive_the_wire() -> CheckResult {
    // the same request through encode → byte stream → decoder → device → reply frame
    let mut d = device();
    let mut buf = [0u8; pam_protocol::MAX_FRAME];
    let req = Request {
        id: 9,
        body: RequestBody::GetConfig(ConfigSection::Robot),
        session: SESSION,
    };
    let n = pam_protocol::encode_frame(&req, &mut buf).map_err(|_| Failure {
        what: "encode",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    let mut dec = pam_protocol::FrameDecoder::<Request>::new();
    let mut reply = None;
    for &b in &buf[..n] {
        if let Some(frame) = dec.push(b) {
            reply = Some(d.handle_frame(frame));
        }
    }
    let reply = reply.ok_or(Failure {
        what: "frame decoded",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    let n = pam_protocol::encode_frame(&DeviceMessage::Reply(reply), &mut buf).unwrap_or(0);
    let mut dec = pam_protocol::FrameDecoder::<DeviceMessage>::new();
    let mut got = None;
    for &b in &buf[..n] {
        if let Some(Ok(m)) = dec.push(b) {
            got = Some(m);
        }
    }
    holds(
        "robot parameters came back",
        got == Some(DeviceMessage::Reply(Reply {
            id: 9,
            result: Ok(ReplyData::Config(Config::Robot(
                RobotParams::thesis().into(),
            ))),
        })),
    )
}
