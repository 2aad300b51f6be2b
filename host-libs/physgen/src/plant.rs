//! The rig in one state: the arm's angles and rates, each muscle's pressure and each
//! regulator's servo state, advanced by a fixed-step RK4; the friction and hysteresis
//! states advanced after each step.

use std::collections::VecDeque;

use pam_model::kinematics::Kinematics;
use pam_model::RobotParams;

use crate::arm::{rk4, Arm};
use crate::friction::{BoucWen, LuGre, MaxwellSlip};
use crate::muscle::{Muscle, Regulator};

/// State: α1, α2, α̇1, α̇2, four muscle pressures (channel order), four servo outputs and
/// their rates.
pub const NS: usize = 16;

/// How the hand (or the blocks) hold the handle: a spring-damper to a target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hand {
    pub k_n_per_m: f64,
    pub b_n_s_per_m: f64,
}

/// The effects a plant may carry beyond the nominal rig.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Effects {
    /// LuGre between the handle's carrier ball and the table, per user axis.
    pub handle_lugre: Option<LuGre>,
    /// LuGre in each joint's bearings and pulley (torque units, rad).
    pub joint_lugre: Option<[LuGre; 2]>,
    /// Generalized Maxwell-slip in each joint (torque units, rad).
    pub joint_gms: Option<[MaxwellSlip; 2]>,
    /// Bouc–Wen in the muscles' force–contraction relation; its force is `n_per_bar` × the
    /// muscle's pressure, so the loop widens as the pressure rises.
    pub muscle_bouc_wen: Option<(BoucWen, f64)>,
    /// Whether the Bouc–Wen state follows the pressure (bar) instead of the contraction:
    /// the force–pressure loop of a muscle held at one length.
    pub bouc_wen_on_pressure: bool,
}

/// The friction and hysteresis states.
#[derive(Clone, Debug, Default)]
struct Hidden {
    handle_z: [f64; 2],
    joint_z: [f64; 2],
    gms_z: [Vec<f64>; 2],
    /// Per joint, per muscle (model order).
    bw_z: [[f64; 2]; 2],
}

pub struct Plant {
    pub arm: Arm,
    pub kin: Kinematics<f64>,
    pub muscles: [Muscle; 2],
    pub pulley_m: [f64; 2],
    pub eps0: [f64; 2],
    pub channel_of_muscle: [[usize; 2]; 2],
    pub regulators: [Regulator; 4],
    pub hand: Hand,
    pub effects: Effects,
    pub dt_s: f64,
    y: [f64; NS],
    hidden: Hidden,
    setpoints: VecDeque<[f64; 4]>,
}

/// What one step leaves for the log.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub alpha_rad: [f64; 2],
    /// The force the robot exerts on the hand, user frame.
    pub force_n: [f64; 2],
    pub pressure_bar: [f64; 4],
}

impl Plant {
    pub fn new(
        params: &RobotParams<f64>,
        regulators: [Regulator; 4],
        hand: Hand,
        effects: Effects,
        dt_s: f64,
    ) -> Self {
        let j = &params.joints;
        let map = |k: usize| {
            [
                j[k].channel_of_muscle[0] as usize & 3,
                j[k].channel_of_muscle[1] as usize & 3,
            ]
        };
        let mut hidden = Hidden::default();
        if let Some(g) = &effects.joint_gms {
            hidden.gms_z = [vec![0.0; g[0].k.len()], vec![0.0; g[1].k.len()]];
        }
        Plant {
            arm: Arm::nominal(params),
            kin: Kinematics::new(params),
            muscles: [
                Muscle::festo_20(j[0].muscle_rest_length_m),
                Muscle::festo_20(j[1].muscle_rest_length_m),
            ],
            pulley_m: [j[0].pulley_radius_m, j[1].pulley_radius_m],
            eps0: [j[0].epsilon0(), j[1].epsilon0()],
            channel_of_muscle: [map(0), map(1)],
            regulators,
            hand,
            effects,
            dt_s,
            y: [0.0; NS],
            hidden,
            setpoints: VecDeque::new(),
        }
    }

    /// Rests the arm at `alpha_rad` with every muscle at its regulator's set-point.
    pub fn reset(&mut self, alpha_rad: [f64; 2], currents_ma: [f64; 4]) {
        self.y = [0.0; NS];
        self.y[0] = alpha_rad[0];
        self.y[1] = alpha_rad[1];
        for c in 0..4 {
            let sp = self.regulators[c]
                .setpoint_bar(currents_ma[c])
                .min(self.regulators[c].cap_bar);
            self.y[4 + c] = sp;
            self.y[8 + c] = sp;
        }
        self.setpoints.clear();
    }

    pub fn alpha_rad(&self) -> [f64; 2] {
        [self.y[0], self.y[1]]
    }

    /// Contraction and its rate of joint j's muscle m (eq. 2.9: muscle 1 lengthens as α grows).
    fn contraction(&self, j: usize, m: usize, alpha: f64, alpha_dot: f64) -> (f64, f64) {
        let r = self.pulley_m[j] / self.muscles[j].rest_length_m;
        let s = if m == 0 { -1.0 } else { 1.0 };
        (self.eps0[j] + s * r * alpha, s * r * alpha_dot)
    }

    /// The hand's force on the handle (user frame) for the state and the hand's target.
    fn hand_force(&self, y: &[f64; NS], target: &([f64; 2], [f64; 2])) -> [f64; 2] {
        let a = [y[0], y[1]];
        let x = self.kin.forward_user(a);
        let v = self.kin.jacobian(a).mul_vec([y[2], y[3]]);
        let (xt, vt) = target;
        [0, 1]
            .map(|i| self.hand.k_n_per_m * (xt[i] - x[i]) + self.hand.b_n_s_per_m * (vt[i] - v[i]))
    }

    fn derivative(
        &self,
        y: &[f64; NS],
        setpoint: &[f64; 4],
        target: &([f64; 2], [f64; 2]),
    ) -> [f64; NS] {
        let mut d = [0.0; NS];
        let (a, ad) = ([y[0], y[1]], [y[2], y[3]]);
        let jac = self.kin.jacobian(a);
        let mut tau = [0.0; 2];
        for j in 0..2 {
            let mut f = [0.0; 2];
            for m in 0..2 {
                let ch = self.channel_of_muscle[j][m];
                let (eps, eps_dot) = self.contraction(j, m, a[j], ad[j]);
                let p = y[4 + ch];
                let mut fm = self.muscles[j].force_n(eps, p);
                if let Some((_, n_per_bar)) = &self.effects.muscle_bouc_wen {
                    fm -= n_per_bar * p.max(0.0) * self.hidden.bw_z[j][m];
                }
                f[m] = fm.max(0.0);
                d[4 + ch] =
                    self.regulators[ch].fill_rate(&self.muscles[j], p, y[8 + ch], eps, eps_dot);
            }
            tau[j] = self.pulley_m[j] * (f[1] - f[0]);
            if let Some(l) = &self.effects.joint_lugre {
                tau[j] -= l[j].force(self.hidden.joint_z[j], ad[j]);
            }
            if let Some(g) = &self.effects.joint_gms {
                tau[j] -= g[j].force(&self.hidden.gms_z[j], ad[j]);
            }
        }
        let mut fh = self.hand_force(y, target);
        if let Some(l) = &self.effects.handle_lugre {
            let v = jac.mul_vec(ad);
            for i in 0..2 {
                fh[i] -= l.force(self.hidden.handle_z[i], v[i]);
            }
        }
        let th = jac.transpose().mul_vec(fh);
        tau = [tau[0] + th[0], tau[1] + th[1]];
        let theta2 = self.kin.theta(a)[1];
        let acc = self.arm.acceleration(theta2, ad, tau);
        d[0] = ad[0];
        d[1] = ad[1];
        d[2] = acc[0];
        d[3] = acc[1];
        for c in 0..4 {
            let (xd, xdd) = self.regulators[c].servo_rate(y[8 + c], y[12 + c], setpoint[c]);
            d[8 + c] = xd;
            d[12 + c] = xdd;
        }
        d
    }

    /// One step with the converters' currents and the hand's target (position, velocity)
    /// at the end of the step.
    pub fn step(&mut self, currents_ma: [f64; 4], target: ([f64; 2], [f64; 2])) -> Sample {
        let sp = [0, 1, 2, 3].map(|c| self.regulators[c].setpoint_bar(currents_ma[c]));
        self.setpoints.push_back(sp);
        let longest = self
            .regulators
            .iter()
            .map(|r| r.dead_steps)
            .max()
            .unwrap_or(0);
        while self.setpoints.len() > longest + 1 {
            self.setpoints.pop_front();
        }
        let n = self.setpoints.len();
        let delayed = [0, 1, 2, 3].map(|c| {
            let back = self.regulators[c].dead_steps.min(n - 1);
            self.setpoints[n - 1 - back][c]
        });
        let y0 = self.y;
        self.y = rk4(&y0, self.dt_s, |y| self.derivative(y, &delayed, &target));
        self.advance_hidden(&y0);
        let fh = self.hand_force(&self.y, &target);
        Sample {
            alpha_rad: [self.y[0], self.y[1]],
            force_n: [-fh[0], -fh[1]],
            pressure_bar: [self.y[4], self.y[5], self.y[6], self.y[7]],
        }
    }

    fn advance_hidden(&mut self, y0: &[f64; NS]) {
        let dt = self.dt_s;
        let (a, ad) = ([self.y[0], self.y[1]], [self.y[2], self.y[3]]);
        if let Some(l) = &self.effects.handle_lugre {
            let v = self.kin.jacobian(a).mul_vec(ad);
            for i in 0..2 {
                self.hidden.handle_z[i] = l.advance(self.hidden.handle_z[i], v[i], dt);
            }
        }
        if let Some(l) = &self.effects.joint_lugre {
            for j in 0..2 {
                self.hidden.joint_z[j] = l[j].advance(self.hidden.joint_z[j], ad[j], dt);
            }
        }
        if let Some(g) = &self.effects.joint_gms {
            for j in 0..2 {
                g[j].advance(&mut self.hidden.gms_z[j], self.y[j] - y0[j], ad[j]);
            }
        }
        if let Some((bw, _)) = self.effects.muscle_bouc_wen {
            for j in 0..2 {
                for m in 0..2 {
                    let rate = if self.effects.bouc_wen_on_pressure {
                        let ch = self.channel_of_muscle[j][m];
                        (self.y[4 + ch] - y0[4 + ch]) / dt
                    } else {
                        self.contraction(j, m, a[j], ad[j]).1
                    };
                    self.hidden.bw_z[j][m] = bw.advance(self.hidden.bw_z[j][m], rate, dt);
                }
            }
        }
    }

    /// Whether the state is finite.
    pub fn finite(&self) -> bool {
        self.y.iter().all(|v| v.is_finite())
    }
}
