//! Properties of the device over everything a host can send: for any sequence of requests
//! (configurations accepted or not, any calibration, modes, arming, silence) interleaved
//! with control periods,
//!
//! * every output current is finite and within 4–20 mA;
//! * disarmed, or faulted by anything but a lone command timeout, every output is exactly
//!   `VENT_CURRENT_MA`; a command timeout's ramp reaches it within its ceiling;
//! * every protection stays enabled: the limits in force pass their ceilings
//!   (`SafetyConfig::validate`), the pressure law never starts below the vent current, and
//!   while armed a limit only ever tightens.

use pam_control::safety::ceiling::TIMEOUT_RAMP_MAX_S;
use pam_control::{Faults, Mode, SafetyConfig, State, MAX_LOOP_CURRENT_MA, VENT_CURRENT_MA};
use pam_device::checks::OPTIONS;
use pam_device::{Device, RawSensors, StepTiming};
use pam_model::RobotParams;
use pam_protocol::{
    Calibration, Config, OutputCalibration, ReplyData, Request, RequestBody, SessionId, NO_SESSION,
    PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
};
use proptest::prelude::*;

/// One thing the host (or time) does.
#[derive(Clone, Debug)]
enum Op {
    /// Periods with the encoders moving by `delta` counts each and the load cell at `volts`
    /// (dithering), the host silent.
    Steps {
        n: u16,
        delta: [i8; 2],
        volts: [f32; 2],
    },
    Heartbeat,
    /// The pressures mode's service interlock on or off.
    Service(bool),
    Arm,
    Disarm,
    Home,
    Tare,
    ClearFaults,
    SetMode(Mode),
    Limits(SafetyConfig),
    /// The robot parameters with the pressure law's current range and the modes' least
    /// pressure changed.
    Robot {
        current_min_ma: f32,
        current_max_ma: f32,
        pressure_min_bar: f32,
    },
    /// The output calibration of every channel.
    Output {
        gain: f32,
        offset_ma: f32,
    },
}

/// A value anywhere: inside, at or beyond any limit, or not a number.
fn any_f32(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => lo..hi,
        1 => Just(0.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => -1.0e6f32..1.0e6,
    ]
}

fn vec2(lo: f32, hi: f32) -> impl Strategy<Value = [f32; 2]> {
    [any_f32(lo, hi), any_f32(lo, hi)]
}

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![
        Just(Mode::Idle),
        [
            any_f32(0.0, 5.5),
            any_f32(0.0, 5.5),
            any_f32(0.0, 5.5),
            any_f32(0.0, 5.5)
        ]
        .prop_map(|pressure_bar| Mode::Pressures { pressure_bar }),
        (vec2(-0.8, 0.8), vec2(-250.0, 250.0), vec2(0.0, 600.0)).prop_map(
            |(alpha_rad, torque_nm, stiffness_nm_per_rad)| Mode::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            }
        ),
        (vec2(-120.0, 120.0), vec2(0.0, 600.0), any::<bool>()).prop_map(
            |(force_n, stiffness_nm_per_rad, feed_forward)| Mode::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            }
        ),
        (
            vec2(-120.0, 120.0),
            vec2(0.0, 600.0),
            any::<bool>(),
            any_f32(0.0, 25.0)
        )
            .prop_map(
                |(force_n, stiffness_nm_per_rad, feed_forward, gain_scale)| Mode::ForceClosedLoop {
                    force_n,
                    stiffness_nm_per_rad,
                    feed_forward,
                    gain_scale,
                }
            ),
        (
            vec2(-0.2, 0.2),
            vec2(0.0, 3000.0),
            vec2(0.0, 300.0),
            vec2(0.0, 10.0)
        )
            .prop_map(
                |(target_user_m, stiffness_n_per_m, damping_n_s_per_m, mass_kg)| Mode::Impedance {
                    target_user_m,
                    stiffness_n_per_m,
                    damping_n_s_per_m,
                    mass_kg,
                }
            ),
    ]
}

/// Limits around the ceilings: often inside, often beyond, sometimes not a number.
fn limits() -> impl Strategy<Value = SafetyConfig> {
    (
        (
            prop_oneof![Just(0.001f32), Just(0.002), Just(0.010), Just(0.020)],
            any_f32(0.0, 2.0),
        ),
        (any_f32(0.0, 200.0), any_f32(0.0, 20.0), any_f32(0.0, 40.0)),
        (any_f32(0.0, 0.3), any_f32(0.0, 400.0), 0u32..2000),
        (
            any_f32(0.0, 400.0),
            any_f32(0.0, 1000.0),
            any_f32(0.0, 200.0),
            0u32..120,
        ),
    )
        .prop_map(
            |((period, timeout), (slew, ramp, speed), (margin, cell, stuck), (t, k, f, o))| {
                SafetyConfig {
                    period_s: period,
                    command_timeout_s: timeout,
                    slew_bar_per_s: slew,
                    timeout_ramp_bar_per_s: ramp,
                    max_joint_speed_rad_s: speed,
                    angle_margin_rad: margin,
                    loadcell_limit_n: cell,
                    loadcell_stuck_samples: stuck,
                    max_request_torque_nm: t,
                    max_request_stiffness_nm_per_rad: k,
                    max_request_force_n: f,
                    overrun_fault_periods: o,
                }
            },
        )
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        8 => (1u16..400, [-8i8..8, -8i8..8], [-0.5f32..0.5, -0.5f32..0.5])
            .prop_map(|(n, delta, volts)| Op::Steps { n, delta, volts }),
        4 => Just(Op::Heartbeat),
        2 => any::<bool>().prop_map(Op::Service),
        3 => Just(Op::Arm),
        1 => Just(Op::Disarm),
        2 => Just(Op::Home),
        1 => Just(Op::Tare),
        2 => Just(Op::ClearFaults),
        6 => mode().prop_map(Op::SetMode),
        3 => limits().prop_map(Op::Limits),
        2 => (any_f32(0.0, 24.0), any_f32(0.0, 24.0), any_f32(0.0, 5.0)).prop_map(
            |(current_min_ma, current_max_ma, pressure_min_bar)| Op::Robot {
                current_min_ma,
                current_max_ma,
                pressure_min_bar,
            }
        ),
        2 => (any_f32(0.4, 1.6), any_f32(-2.5, 2.5))
            .prop_map(|(gain, offset_ma)| Op::Output { gain, offset_ma }),
    ]
}

struct Rig {
    device: Device,
    counts: [u32; 2],
    k: u32,
    /// Periods since the controller faulted with a lone command timeout.
    ramp_periods: u32,
    /// The session the device gave this host: every request after the handshake carries it.
    session: SessionId,
}

impl Rig {
    fn request(&mut self, body: RequestBody) {
        let reply = self.device.handle(&Request {
            id: 1,
            body,
            session: self.session,
        });
        if let Ok(ReplyData::Hello(info)) = reply.result {
            self.session = info.session;
        }
    }

    fn step(&mut self, volts: [f32; 2]) -> Result<(), TestCaseError> {
        self.k = self.k.wrapping_add(1);
        let dither = if self.k.is_multiple_of(2) {
            2e-4
        } else {
            -2e-4
        };
        let out = self.device.step(
            RawSensors {
                encoder_counts: self.counts,
                loadcell_volts: [volts[0] + dither, volts[1]],
            },
            StepTiming::default(),
        );
        let c = self.device.controller();
        for i in out.current_ma {
            prop_assert!(
                i.is_finite() && (VENT_CURRENT_MA..=MAX_LOOP_CURRENT_MA).contains(&i),
                "current {} mA outside 4–20 mA",
                i
            );
        }
        let state = c.state();
        if state == State::Disarmed
            || (state == State::Faulted && c.faults() != Faults::COMMAND_TIMEOUT)
        {
            prop_assert_eq!(out.current_ma, [VENT_CURRENT_MA; 4], "{:?}", c.faults());
        }
        if state == State::Faulted && c.faults() == Faults::COMMAND_TIMEOUT {
            self.ramp_periods += 1;
            let period_s = c.safety().period_s;
            let bound = (TIMEOUT_RAMP_MAX_S / period_s).ceil() as u32 + 1;
            if self.ramp_periods > bound {
                prop_assert_eq!(out.current_ma, [VENT_CURRENT_MA; 4], "the ramp ended");
            }
        } else {
            self.ramp_periods = 0;
        }
        Ok(())
    }

    fn apply(&mut self, op: &Op) -> Result<(), TestCaseError> {
        match *op {
            Op::Steps { n, delta, volts } => {
                for _ in 0..n {
                    for (count, d) in self.counts.iter_mut().zip(delta) {
                        *count = count.wrapping_add(d as i32 as u32);
                    }
                    self.step(volts)?;
                }
            }
            Op::Heartbeat => self.request(RequestBody::Heartbeat),
            Op::Service(enabled) => self.request(RequestBody::SetServiceMode { enabled }),
            Op::Arm => self.request(RequestBody::Arm),
            Op::Disarm => self.request(RequestBody::Disarm),
            Op::Home => self.request(RequestBody::Home),
            Op::Tare => self.request(RequestBody::Tare),
            Op::ClearFaults => self.request(RequestBody::ClearFaults),
            Op::SetMode(mode) => self.request(RequestBody::SetMode(mode.into())),
            Op::Limits(limits) => {
                self.request(RequestBody::SetConfig(Config::Limits(limits.into())))
            }
            Op::Robot {
                current_min_ma,
                current_max_ma,
                pressure_min_bar,
            } => {
                let mut p = self.device.controller().model().params;
                p.ip.current_min_ma = current_min_ma;
                p.ip.current_max_ma = current_max_ma;
                p.pressure.min_bar = pressure_min_bar;
                self.request(RequestBody::SetConfig(Config::Robot(p.into())));
            }
            Op::Output { gain, offset_ma } => {
                let mut cal: Calibration = self.device.calibration();
                cal.output = [OutputCalibration { gain, offset_ma }; 4];
                self.request(RequestBody::SetConfig(Config::Calibration(cal)));
            }
        }
        Ok(())
    }
}

/// What must hold of the configuration in force after every operation.
fn protections_enabled(
    d: &Device,
    before: &SafetyConfig,
    was_armed: bool,
) -> Result<(), TestCaseError> {
    let c = d.controller();
    let now = c.safety();
    prop_assert!(
        now.validate().is_ok(),
        "limits beyond their ceilings: {:?}",
        now
    );
    prop_assert!(c.model().params.ip.current_min_ma >= VENT_CURRENT_MA);
    if was_armed && c.state() == State::Armed {
        prop_assert!(
            before.may_apply_while_armed(now),
            "loosened while armed: {:?}",
            now
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn outputs_stay_safe_and_protections_enabled(ops in proptest::collection::vec(op(), 1..40)) {
        let mut rig = Rig {
            device: Device::new(RobotParams::thesis(), SafetyConfig::default_1khz(), OPTIONS),
            counts: [1000, 2000],
            k: 0,
            ramp_periods: 0,
            session: NO_SESSION,
        };
        rig.request(RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        });
        prop_assert!(rig.session != NO_SESSION, "the handshake gave no session");
        rig.step([0.02, -0.01])?;
        for op in &ops {
            let before = *rig.device.controller().safety();
            let was_armed = rig.device.controller().state() == State::Armed;
            rig.apply(op)?;
            protections_enabled(&rig.device, &before, was_armed)?;
        }
    }
}
