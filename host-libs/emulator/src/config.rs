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
    /// in a pressures mode that follows a force mode in the same arming (the converters'
    /// step of the commissioning); free otherwise, so that joint mode can first bring the
    /// arm to a pose.
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
    /// Wiring mistakes of the emulated rig (`Miswire`); empty: wired right.
    pub miswiring: Vec<Miswire>,
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
            miswiring: Vec::new(),
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

/// A wiring or mounting mistake of the emulated rig, the traps a commissioning must catch.
///
/// Each acts between the twin and the device, where the real mistake would be: the
/// converters' currents are permuted after the device drives them, the sensors' signals are
/// changed before the device reads them. The device's configuration is left as it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Miswire {
    /// The loop currents of output channels `a` and `b` (0-based) reach each other's
    /// converter.
    SwapChannels { a: usize, b: usize },
    /// Joint 1's muscles are labelled the wrong way round (§2.3, last paragraph): its two
    /// channels (1 and 2) are swapped.
    SwapJoint1Muscles,
    /// The encoder of `joint` (0-based) counts the other way.
    EncoderInverted { joint: usize },
    /// The encoder of `joint` gives `scale` times the counts per revolution configured.
    EncoderCounts { joint: usize, scale: f64 },
    /// The load cell is mounted turned by `deg` degrees about the handle's axis.
    LoadCellRotated { deg: f64 },
    /// One load-cell channel (`axis` 0 = X, 1 = Z) is wired with its sign inverted.
    LoadCellInverted { axis: usize },
    /// One load-cell channel's amplifier has `scale` times the gain configured.
    LoadCellGain { axis: usize, scale: f64 },
    /// The two load-cell channels reach each other's ADC input.
    LoadCellAxesSwapped,
    /// Something leaned on the handle when the tare was taken: the load cell reads this
    /// force, N, in its own frame, with the handle free.
    TareOffset { x_n: f64, z_n: f64 },
    /// The arm rests `deg` degrees off the neutral pose at power-up (joint `joint`, 0-based),
    /// where the procedure homes it: the encoder's zero is off by that angle.
    EncoderZero { joint: usize, deg: f64 },
    /// The converter of channel `channel` (0-based) is slow: its loop current reaches the
    /// converter through a first-order lag of `tau_s` seconds (a clogged pilot or filter).
    SlowConverter { channel: usize, tau_s: f64 },
}

impl Miswire {
    /// Every kind, as `pamctl sim --miswire` spells it, with an example.
    pub const KINDS: &'static [&'static str] = &[
        "swap_channels:1,2",
        "swap_joint1_muscles",
        "encoder_inverted:joint=1",
        "encoder_counts:joint=2,scale=2",
        "loadcell_rotated:deg=30",
        "loadcell_inverted:axis=x",
        "loadcell_gain:axis=z,scale=1.5",
        "loadcell_axes_swapped",
        "tare_offset:x=8,z=0",
        "encoder_zero:joint=1,deg=3",
        "slow_converter:channel=2,tau=0.08",
    ];

    /// Parses `KIND` or `KIND:PARAMS` (see [`Miswire::KINDS`]).
    pub fn parse(text: &str) -> Result<Miswire, crate::EmulatorError> {
        let text = text.trim();
        let bad = |reason: &str| crate::EmulatorError::Miswire {
            text: text.to_string(),
            reason: reason.to_string(),
        };
        let (kind, params) = text.split_once(':').unwrap_or((text, ""));
        let value = |key: &str| -> Option<&str> {
            params
                .split(',')
                .filter_map(|p| p.split_once('='))
                .find(|(k, _)| k.trim() == key)
                .map(|(_, v)| v.trim())
        };
        let number = |key: &str| -> Result<f64, crate::EmulatorError> {
            value(key)
                .ok_or_else(|| bad(&format!("needs {key}=NUMBER")))?
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(&format!("{key} must be a number")))
        };
        let joint = || -> Result<usize, crate::EmulatorError> {
            match value("joint") {
                Some("1") => Ok(0),
                Some("2") => Ok(1),
                _ => Err(bad("needs joint=1 or joint=2")),
            }
        };
        let axis = || -> Result<usize, crate::EmulatorError> {
            match value("axis") {
                Some("x") | Some("X") => Ok(0),
                Some("z") | Some("Z") => Ok(1),
                _ => Err(bad("needs axis=x or axis=z")),
            }
        };
        let scale = || -> Result<f64, crate::EmulatorError> {
            let s = number("scale")?;
            if s > 0.0 {
                Ok(s)
            } else {
                Err(bad("scale must be positive"))
            }
        };
        Ok(match kind {
            "swap_channels" => {
                let ch: Vec<usize> = params
                    .split(',')
                    .filter_map(|c| c.trim().parse::<usize>().ok())
                    .collect();
                match ch[..] {
                    [a, b] if (1..=4).contains(&a) && (1..=4).contains(&b) && a != b => {
                        Miswire::SwapChannels { a: a - 1, b: b - 1 }
                    }
                    _ => {
                        return Err(bad(
                            "needs two different channels 1–4, e.g. swap_channels:1,3",
                        ))
                    }
                }
            }
            "swap_joint1_muscles" => Miswire::SwapJoint1Muscles,
            "encoder_inverted" => Miswire::EncoderInverted { joint: joint()? },
            "encoder_counts" => Miswire::EncoderCounts {
                joint: joint()?,
                scale: scale()?,
            },
            "loadcell_rotated" => Miswire::LoadCellRotated {
                deg: number("deg")?,
            },
            "loadcell_inverted" => Miswire::LoadCellInverted { axis: axis()? },
            "loadcell_gain" => Miswire::LoadCellGain {
                axis: axis()?,
                scale: scale()?,
            },
            "loadcell_axes_swapped" => Miswire::LoadCellAxesSwapped,
            "tare_offset" => Miswire::TareOffset {
                x_n: value("x").map_or(Ok(0.0), |_| number("x"))?,
                z_n: value("z").map_or(Ok(0.0), |_| number("z"))?,
            },
            "encoder_zero" => Miswire::EncoderZero {
                joint: joint()?,
                deg: number("deg")?,
            },
            "slow_converter" => {
                let channel = match value("channel").and_then(|c| c.parse::<usize>().ok()) {
                    Some(c) if (1..=4).contains(&c) => c - 1,
                    _ => return Err(bad("needs channel=1–4")),
                };
                let tau_s = number("tau")?;
                if tau_s <= 0.0 {
                    return Err(bad("tau must be positive (seconds)"));
                }
                Miswire::SlowConverter { channel, tau_s }
            }
            _ => return Err(bad("unknown miswiring")),
        })
    }

    /// The converters' currents, in output-channel order, as the miswired outputs deliver
    /// them to the converters.
    pub fn at_converters(&self, driven_ma: [f64; 4]) -> [f64; 4] {
        let mut out = driven_ma;
        match *self {
            Miswire::SwapChannels { a, b } => out.swap(a, b),
            Miswire::SwapJoint1Muscles => out.swap(0, 1),
            _ => {}
        }
        out
    }

    /// Where the arm rests at power-up, rad from the neutral pose.
    pub fn rest_pose_rad(&self) -> [f64; 2] {
        let mut out = [0.0; 2];
        if let Miswire::EncoderZero { joint, deg } = *self {
            out[joint] = deg.to_radians();
        }
        out
    }

    /// The channel whose converter lags, and its time constant, s.
    pub fn converter_lag(&self) -> Option<(usize, f64)> {
        match *self {
            Miswire::SlowConverter { channel, tau_s } => Some((channel, tau_s)),
            _ => None,
        }
    }

    /// Encoder counts from the neutral pose as the miswired encoders give them.
    pub fn encoder_counts(&self, counts: [i64; 2]) -> [i64; 2] {
        let mut out = counts;
        match *self {
            Miswire::EncoderInverted { joint } => out[joint] = -out[joint],
            Miswire::EncoderCounts { joint, scale } => {
                out[joint] = (out[joint] as f64 * scale).round() as i64
            }
            _ => {}
        }
        out
    }

    /// Load-cell channel voltages as the miswired load cell gives them; `offset_v` is the
    /// channels' zero-force voltage and `gain_n_per_v` their configured gain.
    pub fn loadcell_v(
        &self,
        volts: [f64; 2],
        offset_v: [f64; 2],
        gain_n_per_v: [f64; 2],
    ) -> [f64; 2] {
        let d = [volts[0] - offset_v[0], volts[1] - offset_v[1]];
        let out = match *self {
            // the cell turns on the handle: the force turns in front of the bridges, each
            // with its own gain
            Miswire::LoadCellRotated { deg } => {
                let (s, c) = deg.to_radians().sin_cos();
                let f = [d[0] * gain_n_per_v[0], d[1] * gain_n_per_v[1]];
                let r = [c * f[0] - s * f[1], s * f[0] + c * f[1]];
                [r[0] / gain_n_per_v[0], r[1] / gain_n_per_v[1]]
            }
            Miswire::LoadCellInverted { axis } => {
                let mut o = d;
                o[axis] = -o[axis];
                o
            }
            Miswire::LoadCellGain { axis, scale } => {
                let mut o = d;
                o[axis] *= scale;
                o
            }
            Miswire::LoadCellAxesSwapped => [d[1], d[0]],
            Miswire::TareOffset { x_n, z_n } => {
                [d[0] + x_n / gain_n_per_v[0], d[1] + z_n / gain_n_per_v[1]]
            }
            _ => d,
        };
        [out[0] + offset_v[0], out[1] + offset_v[1]]
    }
}

#[cfg(test)]
mod tests {
    use super::Miswire;

    #[test]
    fn every_listed_miswiring_parses_and_changes_a_signal() {
        let gain = [50.0, 50.0];
        for text in Miswire::KINDS {
            let m = Miswire::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"));
            let currents = m.at_converters([4.0, 8.0, 12.0, 16.0]);
            let counts = m.encoder_counts([100, 200]);
            let volts = m.loadcell_v([0.2, 0.1], [0.0; 2], gain);
            let changed = currents != [4.0, 8.0, 12.0, 16.0]
                || counts != [100, 200]
                || m.rest_pose_rad() != [0.0; 2]
                || m.converter_lag().is_some()
                || (volts[0] - 0.2).abs() > 1e-9
                || (volts[1] - 0.1).abs() > 1e-9;
            assert!(changed, "{text} changes nothing");
        }
        assert!(Miswire::KINDS.len() >= 8);
    }

    #[test]
    fn each_miswiring_acts_as_named() {
        let p = |t: &str| Miswire::parse(t).unwrap();
        assert_eq!(
            p("swap_channels:2,4").at_converters([1.0, 2.0, 3.0, 4.0]),
            [1.0, 4.0, 3.0, 2.0]
        );
        assert_eq!(
            p("swap_joint1_muscles").at_converters([1.0, 2.0, 3.0, 4.0]),
            [2.0, 1.0, 3.0, 4.0]
        );
        assert_eq!(
            p("encoder_inverted:joint=2").encoder_counts([5, 7]),
            [5, -7]
        );
        assert_eq!(
            p("encoder_counts:joint=1,scale=2").encoder_counts([5, 7]),
            [10, 7]
        );
        let r = p("loadcell_rotated:deg=90").loadcell_v([1.5, 0.5], [0.5, 0.5], [1.0; 2]);
        assert!(
            (r[0] - 0.5).abs() < 1e-12 && (r[1] - 1.5).abs() < 1e-12,
            "{r:?}"
        );
        assert_eq!(
            p("loadcell_inverted:axis=z").loadcell_v([1.0, 2.0], [0.0; 2], [1.0; 2]),
            [1.0, -2.0]
        );
        assert_eq!(
            p("loadcell_gain:axis=x,scale=2").loadcell_v([1.0, 2.0], [0.0; 2], [1.0; 2]),
            [2.0, 2.0]
        );
        assert_eq!(
            p("loadcell_axes_swapped").loadcell_v([1.0, 2.0], [0.0; 2], [1.0; 2]),
            [2.0, 1.0]
        );
        assert_eq!(
            p("tare_offset:x=10").loadcell_v([1.0, 2.0], [0.0; 2], [5.0; 2]),
            [3.0, 2.0]
        );
    }

    #[test]
    fn a_wrong_miswiring_is_refused_with_its_reason() {
        for bad in [
            "swap_channels:1,1",
            "swap_channels:0,5",
            "encoder_inverted",
            "encoder_counts:joint=1,scale=-1",
            "loadcell_inverted:axis=y",
            "slow_converter:channel=5,tau=0.2",
            "slow_converter:channel=1,tau=0",
            "encoder_zero:joint=3,deg=1",
            "nonsense",
        ] {
            assert!(Miswire::parse(bad).is_err(), "{bad} accepted");
        }
    }
}
