//! What defines one emulator run.

use pam_control::SafetyConfig;
use pam_protocol::Version;
use pam_twin::EffectSet;

use crate::inject::Scheduled;

/// What holds the handle of the emulated robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum HandleMode {
    /// Nothing touches the handle.
    Free,
    /// The handle is blocked (§5.2 set-up) whenever the device is armed in force mode, and
    /// free otherwise, so that joint mode can first bring the arm to a pose.
    Blocked,
    /// A hand holds the handle still where it is each time the device arms or the mode
    /// changes (at the joint target in joint mode).
    Held,
    /// As `held`, with a relaxed hand: 1000 N/m, 50 N·s/m instead of the firm grip's 5000 N/m,
    /// 100 N·s/m (a patient who does not co-contract: the softest hand the closed force loop
    /// is tested against, docs/closed-loop.md).
    HeldRelaxed,
    /// A scripted operator: armed in joint mode, the hand holds the handle at the joint
    /// target for 3 s, then moves it along the twin's smooth random path (±4 cm,
    /// 0.1–2 Hz) around it, restarting at each new target; armed in force mode it blocks
    /// the handle; otherwise it lets go. It plays the operator of the dynamic trial.
    Operator,
}

/// Everything that defines one emulator run.
#[derive(Clone, Debug)]
pub struct SimConfig {
    pub effects: EffectSet,
    pub handle: HandleMode,
    pub seed: u64,
    /// The device's command timeout (the firmware's default is 0.1 s; separate pamctl
    /// invocations in a script need up to 1 s between them).
    pub command_timeout_s: f32,
    /// The twin's rig: the thesis's model (default) or the rig with the stiffness the
    /// thesis identified (`pam_twin::rig`).
    pub identified_rig: bool,
    /// Faults to inject at given emulated times (`inject`).
    pub injections: Vec<Scheduled>,
    /// The file that holds the emulated configuration flash (`flash`); `None`: in memory.
    pub config_flash: Option<std::path::PathBuf>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            effects: EffectSet::none(),
            handle: HandleMode::Free,
            seed: 0,
            command_timeout_s: SafetyConfig::default_1khz().command_timeout_s,
            identified_rig: false,
            injections: Vec::new(),
            config_flash: None,
        }
    }
}

/// The firmware version the emulator reports (this crate's version, which moves with pamctl's).
pub fn emulator_version() -> Version {
    let v: Vec<u16> = env!("CARGO_PKG_VERSION")
        .split('.')
        .map(|s| s.parse().unwrap_or(0))
        .collect();
    Version {
        major: v.first().copied().unwrap_or(0),
        minor: v.get(1).copied().unwrap_or(0),
        patch: v.get(2).copied().unwrap_or(0),
    }
}
