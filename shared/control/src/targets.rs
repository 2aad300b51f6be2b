//! The step's second stage: the pressures the mode asks for, or the safe state.

use pam_model::{Limited, Vec2};

use crate::faults::Faults;
use crate::force_loop::{ForceLoopConfig, GuardTrip};
use crate::impedance::{
    arm_inertia_force_n, impedance_force_n, reachable_impedance_force_n, Impedance,
    VirtualImpedance, IMPEDANCE_INTEGRAL_SCALE,
};
use crate::mode::{Mode, State};
use crate::motion::SOFT_LIMIT_RAD;
use crate::supervise::Pose;
use crate::supervisor::Controller;

/// What the mode asks the output stage for.
pub(crate) struct Command {
    /// Channel pressures, bar.
    pub target_bar: [f32; 4],
    /// What the model clamped.
    pub limited: Limited,
    pub kind: CommandKind,
}

#[derive(Clone, Copy, PartialEq)]
pub(crate) enum CommandKind {
    /// The mode's pressures, slew-limited.
    Mode,
    /// The link-loss ramp down to the vent.
    TimeoutRamp,
    /// The vent, at once.
    Vent,
}

impl Controller {
    /// The command of the present state and mode. A fault latched by a closed loop's
    /// guard during this stage vents in the same period.
    #[inline(always)]
    pub(crate) fn mode_target(&mut self, pose: &Pose) -> Command {
        let vent = self.model.params.ip.output_min_bar;
        let mut command = match self.state {
            State::Armed if self.mode == Mode::Idle => {
                // vented: the next mode tensions the muscles again first
                self.arm_ramp.reset();
                Command {
                    target_bar: [vent; 4],
                    limited: Limited::NONE,
                    kind: CommandKind::Mode,
                }
            }
            State::Armed => {
                let ramp_done = self.arm_ramp.done();
                let closed_loop = matches!(
                    self.mode,
                    Mode::ForceClosedLoop { .. } | Mode::Impedance { .. }
                );
                let arming = match !ramp_done && closed_loop {
                    true => self.closed_loop_arming(pose),
                    false => None,
                };
                let (target_bar, limited) = match arming {
                    Some(arming) => arming,
                    None => self.armed_target(pose, ramp_done),
                };
                Command {
                    target_bar,
                    limited,
                    kind: CommandKind::Mode,
                }
            }
            // A timeout alone ramps down; any other fault (or a disarm) vents at once.
            State::Faulted if self.faults == Faults::COMMAND_TIMEOUT => Command {
                target_bar: [vent; 4],
                limited: Limited::NONE,
                kind: CommandKind::TimeoutRamp,
            },
            State::Faulted | State::Disarmed => Command {
                target_bar: [vent; 4],
                limited: Limited::NONE,
                kind: CommandKind::Vent,
            },
        };
        // a closed loop's guard faults inside the armed branch: vent this very period
        if self.state != State::Armed && command.kind == CommandKind::Mode {
            command.target_bar = [vent; 4];
            command.kind = CommandKind::Vent;
        }
        command
    }

    /// The armed mode's command: its target, through the tensioning ramp while that lasts
    /// (`ramp_done`: it was over when the period began).
    #[inline(always)]
    fn armed_target(&mut self, pose: &Pose, ramp_done: bool) -> ([f32; 4], Limited) {
        let vent = self.model.params.ip.output_min_bar;
        let (target_bar, limited) = match self.mode {
            Mode::Idle => ([vent; 4], Limited::NONE),
            Mode::Pressures { pressure_bar } => (pressure_bar, Limited::NONE),
            Mode::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            } => self.joint_target(pose, alpha_rad, torque_nm, stiffness_nm_per_rad),
            Mode::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            } => {
                let cmd = self.model.force_command_at(
                    pose.alpha_rad,
                    &pose.trig,
                    force_n,
                    stiffness_nm_per_rad,
                    feed_forward,
                );
                let limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
                let p = [cmd.joints[0].pressure_bar, cmd.joints[1].pressure_bar];
                (self.model.channel_pressures_bar(p), limited)
            }
            Mode::ForceClosedLoop { .. } => self.closed_loop_target(pose),
            Mode::Impedance { .. } => self.impedance_target(pose),
        };
        if ramp_done || self.arm_ramp.done() {
            (target_bar, limited)
        } else {
            (self.tensioning(pose, target_bar), limited)
        }
    }

    /// The tensioning ramp toward the mode's target. The mode's own state starts afresh
    /// every period of it, so the mode begins where the ramp leaves the arm, its loops
    /// without a history of commands that never reached the muscles.
    #[cold]
    #[inline(never)]
    fn tensioning(&mut self, pose: &Pose, target_bar: [f32; 4]) -> [f32; 4] {
        self.shaper.reset();
        self.force_loop.reset();
        self.impedance.reset();
        self.encoders.reset();
        let dt = self.safety.period_s;
        self.arm_ramp
            .step(&self.model, pose.alpha_rad, target_bar, dt)
    }

    /// A closed loop's arming, `None` once it is over and the loop may start: the tensioning
    /// ramp toward the pressures of the loop's own command for no force at the handle at the
    /// measured angles (the impedance mode's muscles at their least stiffness, the force
    /// mode's at its stiffness). The loop's command is built on the force it measures, which
    /// the ramp has not yet made, so the loop starts once the ramp is over, from the force
    /// measured then. What holds the handle (a hand, a block) the force loop learns during
    /// its first step ([`crate::force_loop::ForceLoop::observe_handle`]).
    #[cold]
    #[inline(never)]
    fn closed_loop_arming(&mut self, pose: &Pose) -> Option<([f32; 4], Limited)> {
        let (alpha, trig) = (pose.alpha_rad, &pose.trig);
        // a force target beyond the muscles is flagged from the start, as the loop will scale it
        let mut limited = Limited::NONE;
        let sol = match self.mode {
            Mode::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
                ..
            } => {
                let (cfg, model) = (&self.force_loop_cfg, &self.model);
                let reach =
                    self.force_loop
                        .reachable_scale(cfg, model, alpha, trig, force_n, feed_forward);
                if reach < 1.0 {
                    limited = Limited::TARGET;
                }
                let (zero, taut) = ([0.0; 2], cfg.taut_force_fraction);
                model
                    .force_command_taut_at(alpha, trig, zero, stiffness_nm_per_rad, false, taut)
                    .joints
            }
            Mode::Impedance { .. } => self.model.inverse(alpha, [0.0; 2], [0.0; 2]),
            _ => return None,
        };
        let limited = limited.with(sol[0].limited).with(sol[1].limited);
        let p = [sol[0].pressure_bar, sol[1].pressure_bar];
        let target_bar = self.model.channel_pressures_bar(p);
        Some((self.tensioning(pose, target_bar), limited))
    }

    /// Joint mode: the target shaped from where the arm is (rate and acceleration
    /// limited), kept inside the soft limits, through the inverse model.
    #[inline(always)]
    fn joint_target(
        &mut self,
        pose: &Pose,
        alpha_rad: Vec2<f32>,
        torque_nm: Vec2<f32>,
        stiffness_nm_per_rad: Vec2<f32>,
    ) -> ([f32; 4], Limited) {
        let j = &self.model.params.joints;
        let range = [0, 1].map(|k| {
            (
                j[k].alpha_min_rad + SOFT_LIMIT_RAD,
                j[k].alpha_max_rad - SOFT_LIMIT_RAD,
            )
        });
        let (alpha, torque, clamped) = self.shaper.step(
            alpha_rad,
            torque_nm,
            pose.alpha_rad,
            range,
            self.safety.period_s,
        );
        let sol = self.model.inverse(alpha, torque, stiffness_nm_per_rad);
        let mut limited = sol[0].limited.with(sol[1].limited);
        if clamped {
            limited = limited.with(Limited::TARGET);
        }
        let p = [sol[0].pressure_bar, sol[1].pressure_bar];
        (self.model.channel_pressures_bar(p), limited)
    }

    #[inline(always)]
    fn closed_loop_target(&mut self, pose: &Pose) -> ([f32; 4], Limited) {
        let Mode::ForceClosedLoop {
            force_n,
            stiffness_nm_per_rad,
            feed_forward,
            gain_scale,
        } = self.mode
        else {
            return ([self.model.params.ip.output_min_bar; 4], Limited::NONE);
        };
        let dt = self.safety.period_s;
        let (alpha, trig) = (pose.alpha_rad, &pose.trig);
        // the handle is blocked or held: a loop that moves it lost its force
        let w = self.model.kinematics.forward_world_at(trig);
        let too_fast = handle_too_fast(&mut self.impedance, &self.force_loop_cfg, w, dt);
        // a hand gives way where a block does not: gentler gains
        self.force_loop
            .observe_handle(&self.force_loop_cfg, w, pose.force_user_n, dt);
        // a target beyond the muscles is scaled to what they can give
        let reach = self.force_loop.reachable_scale(
            &self.force_loop_cfg,
            &self.model,
            alpha,
            trig,
            force_n,
            feed_forward,
        );
        let target_n = [reach * force_n[0], reach * force_n[1]];
        let fl = self.force_loop.step(
            &self.force_loop_cfg,
            &self.model.params.ip,
            target_n,
            pose.force_user_n,
            gain_scale,
            self.last_saturated,
            dt,
        );
        // the patient let go while the loop pushes: the reference model asks for a force
        // the load cell no longer reads, and the handle runs
        let released = self.impedance.released(fl.model_n, pose.force_user_n, dt);
        if fl.trip == Some(GuardTrip::ImplausibleLoadCell) {
            self.faults = self.faults.with(Faults::LOADCELL_STUCK);
            self.state = State::Faulted;
        } else if fl.trip.is_some() || too_fast || released {
            self.faults = self.faults.with(Faults::CONTROL_UNSTABLE);
            self.state = State::Faulted;
        }
        // the gain plane: all of it on the feedback, on the feed-forward only at a block
        // (a bet the gentle loop against a hand cannot take back)
        let command_n = if feed_forward {
            let plane = &self.model.params.gain_plane;
            let cfg = &self.force_loop_cfg;
            self.force_loop.through_plane(cfg, &fl, plane, alpha).0
        } else {
            fl.command_n
        };
        // no cable asked to push: the loop's gain stays the model's
        let cmd = self.model.force_command_taut_at(
            alpha,
            trig,
            command_n,
            stiffness_nm_per_rad,
            false,
            self.force_loop_cfg.taut_force_fraction,
        );
        let mut limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
        if reach < 1.0 {
            limited = limited.with(Limited::TARGET);
        }
        let p = [cmd.joints[0].pressure_bar, cmd.joints[1].pressure_bar];
        (self.model.channel_pressures_bar(p), limited)
    }

    #[inline(always)]
    fn impedance_target(&mut self, pose: &Pose) -> ([f32; 4], Limited) {
        let Mode::Impedance {
            target_user_m,
            stiffness_n_per_m,
            damping_n_s_per_m,
            mass_kg,
        } = self.mode
        else {
            return ([self.model.params.ip.output_min_bar; 4], Limited::NONE);
        };
        let dt = self.safety.period_s;
        let (alpha, trig) = (pose.alpha_rad, &pose.trig);
        let w = self.model.kinematics.forward_world_at(trig);
        let home = self.model.kinematics.home_world_m;
        let x_m = [w[0] - home[0], w[1] - home[1]];
        let too_fast = handle_too_fast(&mut self.impedance, &self.force_loop_cfg, x_m, dt);
        // what holds the handle, for the gains once the handle has rung (a relaxed hand)
        self.force_loop
            .observe_handle(&self.force_loop_cfg, x_m, pose.force_user_n, dt);
        let held = if self.impedance.rang() {
            self.force_loop.held_scale(&self.force_loop_cfg)
        } else {
            1.0
        };
        let imp = VirtualImpedance {
            stiffness_n_per_m,
            damping_n_s_per_m,
            mass_kg,
        };
        let f_ref = impedance_force_n(target_user_m, &imp, &self.impedance, x_m);
        // the muscles also move the arm's own mass, behind the load cell
        let inertia = arm_inertia_force_n(&self.model, trig, self.impedance.acceleration_m_s2());
        // against a relaxed hand, the feed-forward's lag would undamp the arm on it
        let inertia = [held * inertia[0], held * inertia[1]];
        // a spring force beyond the muscles is scaled, its direction kept
        let (f_ref, reach) = reachable_impedance_force_n(
            &self.model,
            &self.force_loop_cfg,
            (alpha, trig),
            (f_ref, self.safety.max_request_force_n),
            [self.force_loop.integral_n(), inertia],
        );
        let released = self.impedance.released(f_ref, pose.force_user_n, dt);
        let fl = self.force_loop.step_direct(
            &self.force_loop_cfg,
            &self.model.params.ip,
            f_ref,
            pose.force_user_n,
            [held, IMPEDANCE_INTEGRAL_SCALE],
            self.last_saturated,
            dt,
        );
        if fl.trip.is_some() || too_fast || released {
            self.faults = self.faults.with(Faults::CONTROL_UNSTABLE);
            self.state = State::Faulted;
        }
        // the speed guard and the released-handle detector read the encoders: a stuck one
        // blinds both, and shows as a handle force that changes while the angle does not
        if self.encoders.update(alpha, pose.force_user_n) {
            self.faults = self.faults.with(Faults::STATIC_IMBALANCE);
            self.state = State::Faulted;
        }
        let command_n = [fl.command_n[0] + inertia[0], fl.command_n[1] + inertia[1]];
        // stiffness 0: the inverse model gives the least the muscles can
        let cmd = self
            .model
            .force_command_at(alpha, trig, command_n, [0.0; 2], false);
        let mut limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
        if reach < 1.0 {
            limited = limited.with(Limited::TARGET);
        }
        let p = [cmd.joints[0].pressure_bar, cmd.joints[1].pressure_bar];
        (self.model.channel_pressures_bar(p), limited)
    }
}

/// Tracks the handle's velocity (any frame origin: `x_m` is only differenced) and says
/// whether it exceeds the closed loop's speed guard.
fn handle_too_fast(motion: &mut Impedance, cfg: &ForceLoopConfig, x_m: Vec2<f32>, dt: f32) -> bool {
    let v = motion.track(x_m, dt);
    v[0] * v[0] + v[1] * v[1] > cfg.guard_speed_m_s * cfg.guard_speed_m_s
}
