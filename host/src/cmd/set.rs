//! `pamctl set …`: the control mode and its targets. The device checks every value; the
//! host only parses.

use crate::LinkArgs;
use clap::{Args, Subcommand};
use pam_control::Mode;
use pam_protocol::RequestBody;
use std::io::Write;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct SetArgs {
    #[command(subcommand)]
    pub mode: SetMode,
    /// Keep the mode alive this many seconds (this pamctl is the commander and sends its
    /// keep-alives), or until Ctrl-C with `inf`; without it the device's command timeout
    /// ends the mode soon after pamctl exits. `watch` and `record` meanwhile only listen.
    #[arg(long, global = true, value_name = "SECONDS")]
    pub hold: Option<f64>,
}

#[derive(Subcommand, Debug)]
pub enum SetMode {
    /// Safe outputs (vent).
    Idle,
    /// Four channel pressures, bar. A service mode: the handle's motion is not supervised,
    /// so the device refuses it unless its service interlock is on (`--service`).
    Pressures {
        #[arg(
            value_delimiter = ',',
            allow_negative_numbers = true,
            value_name = "P1,P2,P3,P4"
        )]
        pressure_bar: Vec<f64>,
        /// Turn the device's service interlock on first (disarmed, idle or already in the
        /// pressures mode only); it stays on until the next disarm or fault.
        #[arg(long)]
        service: bool,
    },
    /// Per joint: equilibrium angle, torque and stiffness.
    Joint {
        #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], allow_negative_numbers = true, value_name = "A1,A2")]
        alpha_deg: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], allow_negative_numbers = true, value_name = "T1,T2")]
        torque_nm: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_values_t = [60.0, 27.0], allow_negative_numbers = true, value_name = "K1,K2")]
        stiffness_nm_per_rad: Vec<f64>,
    },
    /// Handle force in the user frame (τ = Jᵀ F at the measured pose).
    Force {
        #[arg(
            long,
            value_delimiter = ',',
            allow_negative_numbers = true,
            value_name = "FX,FY"
        )]
        force_n: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_values_t = [60.0, 27.0], allow_negative_numbers = true, value_name = "K1,K2")]
        stiffness_nm_per_rad: Vec<f64>,
        /// Correct the force with the gain plane (thesis eq. 5.2).
        #[arg(long)]
        feed_forward: bool,
        /// Close the loop on the load cell (docs/closed-loop.md).
        #[arg(long)]
        closed_loop: bool,
        /// With --closed-loop: multiplier of the designed feedback gains (0 < S ≤ 20; the
        /// device's guard faults an unstable loop).
        #[arg(
            long,
            default_value_t = 1.0,
            value_name = "S",
            requires = "closed_loop"
        )]
        gain_scale: f64,
    },
    /// A Cartesian spring-damper about a point (user frame), rendered by the closed force
    /// loop: K = 0 with a small B is transparent (docs/closed-loop.md).
    Impedance {
        #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], allow_negative_numbers = true, value_name = "X,Y")]
        target_m: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], allow_negative_numbers = true, value_name = "KX,KY")]
        stiffness_n_per_m: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_values_t = [5.0, 5.0], allow_negative_numbers = true, value_name = "BX,BY")]
        damping_n_s_per_m: Vec<f64>,
    },
}

fn values<const N: usize>(name: &str, v: &[f64]) -> anyhow::Result<[f32; N]> {
    if v.len() != N {
        return Err(anyhow::anyhow!(
            "{name} takes {N} comma-separated values, got {}",
            v.len()
        ));
    }
    let mut out = [0.0f32; N];
    for (o, x) in out.iter_mut().zip(v) {
        if !x.is_finite() {
            return Err(anyhow::anyhow!("{name}: {x} is not a number"));
        }
        *o = *x as f32;
    }
    Ok(out)
}

pub fn mode_of(m: &SetMode) -> anyhow::Result<Mode> {
    Ok(match m {
        SetMode::Idle => Mode::Idle,
        SetMode::Pressures { pressure_bar, .. } => Mode::Pressures {
            pressure_bar: values::<4>("pressures", pressure_bar)?,
        },
        SetMode::Joint {
            alpha_deg,
            torque_nm,
            stiffness_nm_per_rad,
        } => Mode::Joint {
            alpha_rad: values::<2>("--alpha-deg", alpha_deg)?.map(f32::to_radians),
            torque_nm: values::<2>("--torque-nm", torque_nm)?,
            stiffness_nm_per_rad: values::<2>("--stiffness-nm-per-rad", stiffness_nm_per_rad)?,
        },
        SetMode::Force {
            force_n,
            stiffness_nm_per_rad,
            feed_forward,
            closed_loop: false,
            ..
        } => Mode::Force {
            force_n: values::<2>("--force-n", force_n)?,
            stiffness_nm_per_rad: values::<2>("--stiffness-nm-per-rad", stiffness_nm_per_rad)?,
            feed_forward: *feed_forward,
        },
        SetMode::Force {
            force_n,
            stiffness_nm_per_rad,
            feed_forward,
            closed_loop: true,
            gain_scale,
        } => Mode::ForceClosedLoop {
            force_n: values::<2>("--force-n", force_n)?,
            stiffness_nm_per_rad: values::<2>("--stiffness-nm-per-rad", stiffness_nm_per_rad)?,
            feed_forward: *feed_forward,
            gain_scale: values::<1>("--gain-scale", &[*gain_scale])?[0],
        },
        SetMode::Impedance {
            target_m,
            stiffness_n_per_m,
            damping_n_s_per_m,
        } => Mode::Impedance {
            target_user_m: values::<2>("--target-m", target_m)?,
            stiffness_n_per_m: values::<2>("--stiffness-n-per-m", stiffness_n_per_m)?,
            damping_n_s_per_m: values::<2>("--damping-n-s-per-m", damping_n_s_per_m)?,
            // not on the wire (docs/impedance.md, "Virtual mass")
            mass_kg: [0.0; 2],
        },
    })
}

pub fn run(args: SetArgs, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let mode = mode_of(&args.mode)?;
    let hold = match args.hold {
        Some(h) if h.is_nan() || h < 0.0 => {
            return Err(anyhow::anyhow!(
                "--hold {h}: give a duration in seconds ≥ 0, or inf"
            ))
        }
        h => h.unwrap_or(0.0),
    };
    let client = super::connect(link)?;
    client.start_telemetry();
    if matches!(args.mode, SetMode::Pressures { service: true, .. }) {
        client.set_service_mode(true)?;
    }
    client.command(RequestBody::SetMode(mode.into()))?;
    writeln!(out, "mode set: {}", super::status::describe_mode(&mode))?;
    // a few samples tell whether the target had to be clamped at this pose
    let mut clamped = false;
    let mut scaled = false;
    for _ in 0..5 {
        if let Ok(Some(t)) = client.next_telemetry(Duration::from_millis(20)) {
            // the model's clamping only: the slew limit (LIMITED_OUTPUT) is the normal way
            // to a new target
            clamped |= t.limited & !pam_protocol::LIMITED_OUTPUT != 0;
            scaled |= t.limited & pam_model::Limited::TARGET.0 != 0;
        }
    }
    if scaled {
        writeln!(
            out,
            "warning: the force target is beyond what the muscles can give at this pose: the \
             closed loop scaled it down to what they can, in the same direction"
        )?;
    } else if clamped {
        writeln!(
            out,
            "warning: the target is beyond what the robot can do at this pose: it is clamped \
             (see `pamctl model capability` at the pose)"
        )?;
    }
    if hold > 0.0 {
        let stop = super::interrupted();
        let start = Instant::now();
        while start.elapsed().as_secs_f64() < hold && !stop.load(Ordering::SeqCst) {
            client.heartbeat()?;
            std::thread::sleep(Duration::from_millis(20));
            while let Ok(Some(_)) = client.next_telemetry(Duration::ZERO) {}
        }
        let faults = client.fault_events();
        if let Some(f) = faults.last() {
            return Err(anyhow::anyhow!(
                "the device faulted while holding: {}",
                pam_link::fault_names(f.bits)
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(subcommand)]
        mode: SetMode,
    }

    fn mode(args: &[&str]) -> anyhow::Result<Mode> {
        let cli = Cli::try_parse_from(std::iter::once("set").chain(args.iter().copied()))?;
        mode_of(&cli.mode)
    }

    #[test]
    fn force_open_and_closed_loop() {
        assert_eq!(
            mode(&["force", "--force-n", "9.1,-4", "--feed-forward"]).unwrap(),
            Mode::Force {
                force_n: [9.1, -4.0],
                stiffness_nm_per_rad: [60.0, 27.0],
                feed_forward: true,
            }
        );
        assert_eq!(
            mode(&[
                "force",
                "--force-n",
                "9.1,-4",
                "--closed-loop",
                "--gain-scale",
                "3"
            ])
            .unwrap(),
            Mode::ForceClosedLoop {
                force_n: [9.1, -4.0],
                stiffness_nm_per_rad: [60.0, 27.0],
                feed_forward: false,
                gain_scale: 3.0,
            }
        );
        // the gain scale means nothing open loop
        assert!(mode(&["force", "--force-n", "1,0", "--gain-scale", "3"]).is_err());
        assert!(mode(&[
            "force",
            "--force-n",
            "1,0",
            "--closed-loop",
            "--gain-scale",
            "nan"
        ])
        .is_err());
    }

    #[test]
    fn impedance() {
        assert_eq!(
            mode(&[
                "impedance",
                "--target-m",
                "0.02,-0.01",
                "--stiffness-n-per-m",
                "300,200"
            ])
            .unwrap(),
            Mode::Impedance {
                target_user_m: [0.02, -0.01],
                stiffness_n_per_m: [300.0, 200.0],
                damping_n_s_per_m: [5.0, 5.0],
                mass_kg: [0.0; 2],
            }
        );
        assert!(mode(&["impedance", "--stiffness-n-per-m", "300"]).is_err());
    }
}
