//! The messages. Every type here is fixed-size (no heap) and serialized with postcard:
//! integers as varints, f32 as 4 little-endian bytes, enums as a varint tag. Payloads that
//! carry a domain value use the protocol's own types from [`crate::wire`], and every type
//! is declared through `wire_struct!`/`wire_enum!` so that it enters the
//! [`SCHEMA_FINGERPRINT`].
//!
//! Compatibility rules, in every protocol version: a [`Request`] starts with its id, and
//! `RequestBody::Hello` is variant 0 starting with a `u16` (the protocol version), so that
//! a host can always ask any device for its version; and its reply
//! (`DeviceMessage::Reply` variant 0, `Ok`, `ReplyData::Hello` variant 1) carries a
//! [`DeviceInfo`] that starts with `protocol_version` then `schema_fingerprint`. A device of
//! another version refuses the `Hello` (`UnsupportedVersion`); one of the same version but
//! another build is told apart by the fingerprint.

use crate::wire;
use crate::wire::schema::{fnv_u32, wire_enum, wire_struct, Schema, FNV_OFFSET};
use serde::{Deserialize, Serialize};

/// Version of everything in this module. Bump on any change of the wire format.
/// 2: the protocol's own wire types, `DeviceInfo::schema_fingerprint`.
/// 4: the configuration in flash (`PersistConfig`, `RestoreConfig`, `EraseConfig`, two
/// error codes) and the board's health in `Status` (configuration origin, stack, last CPU
/// fault, VDDA, board checks).
/// 5: `SafetyConfig::overrun_fault_periods` (the configurable count of missed
/// periods that latches `LOOP_OVERRUN`).
/// 6: calibration plausibility (`ErrorCode::Implausible`).
/// 7: the commander: `Request::session`, `Hello::schema_fingerprint` checked by the device,
/// `DeviceInfo::session`, `Heartbeat` from the commander only, `TakeCommand`,
/// `SetServiceMode`, four error
/// codes (`NoSession`, `NotCommander`, `SchemaMismatch`, `ServiceModeOff`).
pub const PROTOCOL_VERSION: u16 = 9;

/// Fingerprint of the wire format: FNV-1a over [`PROTOCOL_VERSION`] and the shape of
/// [`Request`] and [`DeviceMessage`] (every type they contain, see [`crate::wire::schema`]),
/// computed at compile time. The device reports it in [`DeviceInfo`]; the host refuses a
/// device whose fingerprint differs from its own.
pub const SCHEMA_FINGERPRINT: u32 = fnv_u32(
    fnv_u32(
        fnv_u32(FNV_OFFSET, PROTOCOL_VERSION as u32),
        Request::SCHEMA_HASH,
    ),
    DeviceMessage::SCHEMA_HASH,
);

pub type RequestId = u16;

/// The id the device puts on the reply to a frame whose request id it could not read
/// (corrupted frame). Hosts number their requests from 1.
pub const UNKNOWN_REQUEST_ID: RequestId = 0;

/// A host's session with the device: issued by the device in the `Hello` reply, carried by
/// every later request of that host. A token, not a count: the device masks its count of
/// handshakes with a number drawn at boot, so a token from before a reset is not a
/// session after it.
pub type SessionId = u32;

/// The session of a host that has not done the handshake.
pub const NO_SESSION: SessionId = 0;

wire_struct! {
    /// Host → device.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct Request {
        pub id: RequestId,
        pub body: RequestBody,
        /// The token the device gave this host in its `Hello` reply ([`DeviceInfo::session`]);
        /// [`NO_SESSION`] before the handshake. Last, so that every version's `Hello`
        /// frame starts alike.
        pub session: SessionId,
    }
}

wire_enum! {
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum RequestBody {
        /// Handshake: the device answers with [`ReplyData::Hello`] and a new session, or
        /// [`ErrorCode::UnsupportedVersion`] if it does not speak `protocol_version`, or
        /// [`ErrorCode::SchemaMismatch`] if `schema_fingerprint` is not its own
        /// [`SCHEMA_FINGERPRINT`]. `Arm` and `SetMode` need a session.
        Hello {
            protocol_version: u16,
            schema_fingerprint: u32,
        },
        /// Keep-alive of the commander (the session that armed or set the mode last): it
        /// resets the command timeout. Only the commander's `Arm`, `SetMode` and
        /// `Heartbeat` do; any other request (`GetStatus`, telemetry, another session's
        /// heartbeat) does not. From another session while armed: [`ErrorCode::NotCommander`].
        Heartbeat,
        Arm,
        Disarm,
        /// The present encoder position becomes α = 0 (neutral pose). Not while armed.
        Home,
        /// The present load-cell reading becomes zero force. Not while armed.
        Tare,
        /// Clears latched faults (refused while a fault condition persists).
        ClearFaults,
        GetStatus,
        /// Mode and targets; values beyond the absolute limits are refused, values the robot
        /// cannot reach at the pose are clamped and flagged in telemetry. The sender becomes
        /// the commander. The pressures mode needs the service mode
        /// ([`RequestBody::SetServiceMode`]).
        SetMode(wire::Mode),
        GetConfig(ConfigSection),
        /// Replaces one configuration section. Invalid → error reply, nothing changed.
        SetConfig(Config),
        /// Telemetry every `divider` control periods (1 = every period); 0 stops it.
        SetTelemetry {
            divider: u16,
        },
        /// Writes the configuration in use (robot, calibration, limits) to the device's
        /// flash, where the next boot finds it. Not while armed.
        PersistConfig,
        /// Replaces the configuration in use with the one in flash. Not while armed;
        /// `NoStoredConfig` (nothing changed) if the flash holds no good record.
        RestoreConfig,
        /// Erases the configuration in flash (the next boot starts from the defaults); the
        /// configuration in use is unchanged. Not while armed.
        EraseConfig,
        /// The service interlock of the pressures mode (raw channel pressures, no motion
        /// supervision of the handle's target): on only while disarmed, idle or already in
        /// the pressures mode ([`ErrorCode::WrongState`] otherwise); off at any time (leaving the pressures mode for idle). Off at boot
        /// and after every disarm.
        SetServiceMode {
            enabled: bool,
        },
        /// The sender becomes the commander of the armed device without changing the mode
        /// (a client that only watches opts in explicitly to keeping the mode alive);
        /// feeds the command timeout. `WrongState` while not armed.
        TakeCommand,
    }
}

wire_enum! {
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum ConfigSection {
        Robot,
        Calibration,
        Limits,
    }
}

wire_enum! {
    /// One configuration section.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum Config {
        /// Every model parameter (geometry, muscles, I/P law, load cell, gain plane).
        Robot(wire::RobotParams),
        Calibration(Calibration),
        /// Safety limits; `period_s` is the control period (1–10 ms).
        Limits(wire::SafetyConfig),
    }
}

wire_struct! {
    /// Sensor and output calibration of the rig.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct Calibration {
        pub encoder: [EncoderCalibration; 2],
        /// Per-channel volts → newtons. The same storage as `RobotParams::load_cell`.
        pub load_cell: wire::LoadCell,
        pub output: [OutputCalibration; 4],
        /// The output stage (0–3) that drives each I/P channel's converter, in the model's
        /// channel order (`JointParams::channel_of_muscle` names the channels): the I/P
        /// channel map as wired, a permutation of 0–3. `[0, 1, 2, 3]`: stage c drives
        /// channel c (also in a configuration file written without it).
        #[serde(default = "identity_channel_map")]
        pub output_of_channel: [u8; 4],
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct EncoderCalibration {
        /// Counts per joint revolution (quadrature edges included).
        pub counts_per_rev: u32,
        /// +1 or −1: the direction in which counts grow with α.
        pub sign: i8,
        /// The angle, rad, the homed encoder reads at the neutral pose (the homing pose's
        /// angle from the neutral pose, negated): subtracted from every reading.
        /// 0 in a configuration file written without it.
        #[serde(default)]
        pub zero_rad: f32,
    }
}

wire_struct! {
    /// Trim of one 4–20 mA output stage: the stage is asked for `gain · I + offset_ma` so that
    /// it delivers the loop current I.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct OutputCalibration {
        pub gain: f32,
        pub offset_ma: f32,
    }
}

impl Default for EncoderCalibration {
    fn default() -> Self {
        // 2 000-line encoder read on all four edges
        EncoderCalibration {
            counts_per_rev: 8_000,
            sign: 1,
            zero_rad: 0.0,
        }
    }
}

/// Output stage c drives I/P channel c.
pub const IDENTITY_CHANNEL_MAP: [u8; 4] = [0, 1, 2, 3];

fn identity_channel_map() -> [u8; 4] {
    IDENTITY_CHANNEL_MAP
}

impl Default for OutputCalibration {
    fn default() -> Self {
        OutputCalibration {
            gain: 1.0,
            offset_ma: 0.0,
        }
    }
}

wire_enum! {
    /// Device → host.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum DeviceMessage {
        Reply(Reply),
        Telemetry(Telemetry),
        FaultEvent(FaultEvent),
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct Reply {
        pub id: RequestId,
        pub result: Result<ReplyData, ErrorCode>,
    }
}

wire_enum! {
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum ReplyData {
        /// The request was carried out.
        Done,
        Hello(DeviceInfo),
        Status(Status),
        Config(Config),
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub struct Version {
        pub major: u16,
        pub minor: u16,
        pub patch: u16,
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub struct DeviceInfo {
        pub protocol_version: u16,
        /// [`SCHEMA_FINGERPRINT`] of the device's build.
        pub schema_fingerprint: u32,
        pub firmware_version: Version,
        pub period_us: u32,
        /// [`crate::params_hash`] of the robot parameters in use.
        pub params_hash: u32,
        /// This host's session: to put in [`Request::session`] from now on.
        pub session: SessionId,
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct Status {
        pub state: wire::State,
        pub mode: wire::Mode,
        pub faults: u16,
        pub homed: bool,
        pub period_us: u32,
        pub telemetry_divider: u16,
        /// Where the configuration in use came from at boot or at the last restore.
        pub config: ConfigOrigin,
        /// The configuration in use differs from what the next boot would load
        /// (`SetConfig`, `Tare` or `EraseConfig` since the last load or persist).
        pub config_unsaved: bool,
        /// [`BOARD_CHECK_VDDA`] | [`BOARD_CHECK_ADC_DUAL`]: the board checks failing now
        /// (each keeps `SELF_CHECK` latched). Always 0 in the emulator.
        pub board_checks: u8,
        /// The analog supply measured through VREFINT; `None` where nothing measures it.
        pub vdda_v: Option<f32>,
        /// The stack's high-water mark (painted stack); `None` in the emulator.
        pub stack: Option<StackUsage>,
        /// The CPU fault exception that ended the previous run, if one did.
        pub last_cpu_fault: Option<CpuFault>,
        /// The service interlock is on: the pressures mode may be set (`SetServiceMode`;
        /// cleared at every disarm and fault).
        pub service_mode: bool,
    }
}

/// [`Status::board_checks`]: VDDA (through VREFINT) outside its range.
pub const BOARD_CHECK_VDDA: u8 = 1 << 0;
/// [`Status::board_checks`]: ADC1/ADC2 dual mode did not read back as set.
pub const BOARD_CHECK_ADC_DUAL: u8 = 1 << 1;
/// [`Status::board_checks`]: the interface board's output stage can drive current while
/// the MCU is in reset (the first revision, or a board that does not identify itself):
/// arming is refused on it.
pub const BOARD_CHECK_OUTPUT_STAGE: u8 = 1 << 2;

wire_enum! {
    /// Where the configuration in use came from. Every `Defaults…` is the thesis's values;
    /// those marked (fault) latch `SELF_CHECK`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum ConfigOrigin {
        /// The record in flash.
        Flash,
        /// Defaults: the flash holds no record (never persisted, or erased).
        DefaultsNoRecord,
        /// Defaults: the record failed its CRC (fault).
        DefaultsCorrupt,
        /// Defaults: the record was written by a firmware with another layout (fault).
        DefaultsOtherVersion,
        /// Defaults: the record checked, but the device refused its values (fault).
        DefaultsRefused,
        /// Defaults: the flash could not be read (fault), or no store was consulted.
        DefaultsNoStorage,
    }
}

wire_struct! {
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub struct StackUsage {
        /// The deepest the stack has been since boot.
        pub used_max_bytes: u32,
        pub size_bytes: u32,
    }
}

wire_enum! {
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum CpuFaultKind {
        HardFault,
        MemManage,
        BusFault,
        UsageFault,
        /// An interrupt without a handler (`address` holds its number).
        UnexpectedInterrupt,
    }
}

wire_struct! {
    /// The record a CPU fault handler left in no-init RAM before the watchdog reset.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub struct CpuFault {
        pub kind: CpuFaultKind,
        /// The stacked PC (HardFault); 0 where the handler had no exception frame.
        pub pc: u32,
        /// MMFAR/BFAR when valid, the IRQ number for an unexpected interrupt, else 0.
        pub address: u32,
    }
}

wire_enum! {
    /// Why a request was refused. A refused request changes nothing.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum ErrorCode {
        /// The frame was corrupted (CRC, COBS) or did not decode as a request.
        Malformed,
        /// `Hello` with a protocol version this device does not speak.
        UnsupportedVersion,
        /// A value is NaN/∞ or outside its limits.
        OutOfRange,
        /// Not allowed in the present state (e.g. arm while faulted, home while armed).
        WrongState,
        /// Clear refused: a fault condition is still present.
        FaultStillPresent,
        /// Arm refused: the encoders have not been homed.
        NotHomed,
        /// The flash failed (erase, write or read), or this device has no configuration
        /// store.
        StorageFailed,
        /// `RestoreConfig`: the flash holds no good record (see `Status::config`).
        NoStoredConfig,
        /// A calibration the sensors contradict: tare under load, home away from the
        /// previous zero, a load-cell gain that is not positive.
        Implausible,
        /// `Arm` or `SetMode` from a host without a session (no `Hello`, or a session the
        /// device did not issue since its boot).
        NoSession,
        /// A keep-alive from a session that is not the commander, while armed.
        NotCommander,
        /// `Hello` from a host built with another wire schema.
        SchemaMismatch,
        /// The pressures mode while the service mode is off.
        ServiceModeOff,
    }
}

wire_enum! {
    /// Compact summary of [`pam_control::Mode`] for telemetry.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum ModeKind {
        Idle,
        Pressures,
        Joint,
        Force,
        ForceFeedForward,
        /// Appended: closed-loop force, with or without the gain plane.
        ForceClosedLoop,
        /// Appended: Cartesian spring-damper through the closed force loop.
        Impedance,
    }
}

impl ModeKind {
    pub fn of(mode: &pam_control::Mode) -> ModeKind {
        use pam_control::Mode as M;
        match mode {
            M::Idle => ModeKind::Idle,
            M::Pressures { .. } => ModeKind::Pressures,
            M::Joint { .. } => ModeKind::Joint,
            M::Force {
                feed_forward: false,
                ..
            } => ModeKind::Force,
            M::Force {
                feed_forward: true, ..
            } => ModeKind::ForceFeedForward,
            M::ForceClosedLoop { .. } => ModeKind::ForceClosedLoop,
            M::Impedance { .. } => ModeKind::Impedance,
        }
    }
}

/// Bit of [`Telemetry::limited`] set when the slew limit or a converter's range changed the
/// command; the low bits are the model's `Limited` flags (joint 1 | joint 2), and 0x20
/// (`Limited::TARGET`) says a closed-loop or impedance force target was scaled to what the
/// muscles can give, its direction kept.
pub const LIMITED_OUTPUT: u8 = pam_control::mode::LIMITED_OUTPUT;

wire_struct! {
    /// One control-period sample. Encoded size: see [`crate::TELEMETRY_FRAME_MAX`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct Telemetry {
        /// +1 per telemetry frame sent (whatever the divider): a gap is a dropped frame.
        pub seq: u32,
        /// Device time at the sample, µs (wraps after 71 min; the host unwraps it).
        pub time_us: u32,
        pub alpha_rad: [f32; 2],
        /// Force the robot exerts on the handle, user frame.
        pub force_user_n: [f32; 2],
        /// The requested force in force mode, `None` otherwise.
        pub force_ref_n: Option<[f32; 2]>,
        /// Loop current commanded per output channel.
        pub current_ma: [f32; 4],
        /// Pressure commanded per output channel (after limits).
        pub pressure_cmd_bar: [f32; 4],
        pub mode: ModeKind,
        pub state: wire::State,
        pub faults: u16,
        pub limited: u8,
        /// Execution time of the previous control step.
        pub loop_exec_us: u16,
        /// |actual − nominal| start time of this period.
        pub loop_jitter_us: u16,
    }
}

wire_struct! {
    /// Sent once when faults latch (new bits appear).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub struct FaultEvent {
        /// Bit index of the lowest newly latched fault (see `pam_control::Faults`).
        pub code: u8,
        /// Every latched fault bit.
        pub bits: u16,
    }
}
