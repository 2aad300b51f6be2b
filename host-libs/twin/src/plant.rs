//! The plant: four I/P converters, four compressible muscles on two pulleys, two rigid
//! segments, the handle and its surroundings, the sensors. Its configuration is in
//! [`crate::config`] (re-exported here).

use pam_model::cartesian::{coriolis_torques, joint_inertia};
use pam_model::kinematics::Kinematics;
use pam_model::{Mat2, RobotModel, Vec2};

pub use crate::config::{HandSpring, HandleCondition, MechanicsConfig, SensorConfig, TwinConfig};
use crate::effects::{Ctx, EffectSet, HandleForces, MuscleView, RawSensors};
use crate::pneumatics::MuscleVolume;
use crate::rng::Rng;

/// One sample of the sensors, raw and converted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    pub t_s: f64,
    /// Encoder counts from the neutral pose.
    pub encoder_counts: [i64; 2],
    /// Load-cell channel voltages (sensor X, Z) after the ADC.
    pub loadcell_v: [f64; 2],
    /// α from the counts.
    pub alpha_rad: Vec2<f64>,
    /// Load-cell force in its own frame (eq. 2.1).
    pub force_sensor_n: Vec2<f64>,
    /// The same rotated to the user frame at the measured pose (eq. 2.6–2.7): the force the
    /// robot exerts on whatever holds the handle.
    pub force_user_n: Vec2<f64>,
    /// Muscle pressures, channel order (the rig has no pressure sensors; the twin reports the
    /// true ones for the logs).
    pub pressure_bar: [f64; 4],
}

/// The true state of the plant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueState {
    pub t_s: f64,
    pub alpha_rad: Vec2<f64>,
    pub alpha_dot_rad_s: Vec2<f64>,
    /// Muscle gauge pressure, channel order.
    pub pressure_bar: [f64; 4],
    /// Pressure each converter is regulating to (after the command-stage effects).
    pub pressure_set_bar: [f64; 4],
    /// Converter flow state (bar/s in the reference volume).
    pub regulator_flow_bar_s: [f64; 4],
    /// Cable forces, channel order (≥ 0).
    pub muscle_force_n: [f64; 4],
    pub joint_torque_nm: Vec2<f64>,
    pub handle_user_m: Vec2<f64>,
    pub handle_velocity_user_m_s: Vec2<f64>,
    /// Force the robot exerts on whatever holds the handle (hand + environment, or the blocks).
    pub force_on_holder_user_n: Vec2<f64>,
}

pub struct Twin {
    model: RobotModel<f64>,
    cfg: TwinConfig,
    effects: EffectSet,
    volumes: [MuscleVolume; 2],
    /// Reference volume of each channel: the volume at the neutral pose (Table 5.2's set-up).
    volume_ref_m3: [f64; 4],
    /// (joint, model muscle index) of each channel.
    channel_owner: [(usize, usize); 4],
    state: TrueState,
    /// Where each joint's parallel element is anchored (it slips past its break-away).
    parallel_anchor_rad: Vec2<f64>,
    rng: Rng,
}

impl Twin {
    pub fn new(cfg: TwinConfig) -> Self {
        let model = RobotModel::new(cfg.params);
        let mut channel_owner = [(0usize, 0usize); 4];
        for j in 0..2 {
            for m in 0..2 {
                channel_owner[(cfg.params.joints[j].channel_of_muscle[m] & 3) as usize] = (j, m);
            }
        }
        let volumes = [
            MuscleVolume::new(&cfg.pneumatics, cfg.params.joints[0].muscle_rest_length_m),
            MuscleVolume::new(&cfg.pneumatics, cfg.params.joints[1].muscle_rest_length_m),
        ];
        let mut volume_ref_m3 = [0.0; 4];
        for c in 0..4 {
            let (j, _) = channel_owner[c];
            volume_ref_m3[c] = volumes[j].at(model.joints[j].epsilon0).0;
        }
        let mut effects = cfg.effects.clone();
        effects.reset(cfg.seed);
        let p0 = cfg
            .initial_pressure_bar
            .unwrap_or([cfg.params.ip.output_min_bar; 4]);
        let alpha = cfg.initial_alpha_rad;
        let mut twin = Twin {
            rng: Rng::derive(cfg.seed, "sensors"),
            model,
            effects,
            volumes,
            volume_ref_m3,
            channel_owner,
            state: TrueState {
                t_s: 0.0,
                alpha_rad: alpha,
                alpha_dot_rad_s: [0.0; 2],
                pressure_bar: p0,
                pressure_set_bar: p0,
                regulator_flow_bar_s: [0.0; 4],
                muscle_force_n: [0.0; 4],
                joint_torque_nm: [0.0; 2],
                handle_user_m: [0.0; 2],
                handle_velocity_user_m_s: [0.0; 2],
                force_on_holder_user_n: [0.0; 2],
            },
            parallel_anchor_rad: alpha,
            cfg,
        };
        twin.state.handle_user_m = twin.model.kinematics.forward_user(alpha);
        twin
    }

    pub fn state(&self) -> &TrueState {
        &self.state
    }
    pub fn model(&self) -> &RobotModel<f64> {
        &self.model
    }
    pub fn config(&self) -> &TwinConfig {
        &self.cfg
    }
    pub fn effects(&self) -> &EffectSet {
        &self.effects
    }

    /// The parallel element's torque on joint `j` (opposing the deflection from its anchor);
    /// past the break-away the anchor slips along.
    fn parallel_torque_nm(&mut self, j: usize) -> f64 {
        let k = self.cfg.mechanics.parallel_stiffness_nm_per_rad[j];
        if k == 0.0 {
            return 0.0;
        }
        let reach = self.cfg.mechanics.parallel_breakaway_nm[j] / k;
        let alpha = self.state.alpha_rad[j];
        let deflection = alpha - self.parallel_anchor_rad[j];
        if deflection > reach {
            self.parallel_anchor_rad[j] = alpha - reach;
        } else if deflection < -reach {
            self.parallel_anchor_rad[j] = alpha + reach;
        }
        k * (alpha - self.parallel_anchor_rad[j])
    }

    /// Puts the arm at rest at `alpha_rad` (e.g. before a blocked test at a pose).
    pub fn place(&mut self, alpha_rad: Vec2<f64>) {
        self.state.alpha_rad = alpha_rad;
        self.state.alpha_dot_rad_s = [0.0; 2];
        self.parallel_anchor_rad = alpha_rad;
        self.state.handle_user_m = self.model.kinematics.forward_user(alpha_rad);
        self.state.handle_velocity_user_m_s = [0.0; 2];
    }

    /// Advances the plant by `dt_s` with the four loop currents held, and samples the sensors
    /// at the end. Subdivides into steps of at most `max_substep_s`.
    pub fn step(
        &mut self,
        dt_s: f64,
        currents_ma: [f64; 4],
        handle: &HandleCondition,
    ) -> Measurement {
        let dt = if dt_s.is_finite() && dt_s > 0.0 {
            dt_s
        } else {
            0.0
        };
        let n = (dt / self.cfg.max_substep_s.max(1e-6)).ceil().max(1.0) as usize;
        let h = dt / n as f64;
        for k in 0..n {
            // a moving hand's target advances with its velocity inside the step, so a long
            // loop period does not turn the operator's path into a staircase
            let elapsed = k as f64 * h;
            let advance = |s: &HandSpring| HandSpring {
                target_user_m: [
                    s.target_user_m[0] + s.target_velocity_user_m_s[0] * elapsed,
                    s.target_user_m[1] + s.target_velocity_user_m_s[1] * elapsed,
                ],
                ..*s
            };
            let here = match handle {
                HandleCondition::Hand(s) => HandleCondition::Hand(advance(s)),
                HandleCondition::Joint1Locked(Some(s)) => {
                    HandleCondition::Joint1Locked(Some(advance(s)))
                }
                other => *other,
            };
            self.substep(h, &currents_ma, &here);
        }
        self.sample()
    }

    fn ctx(&self, h: f64, blocked: bool) -> Ctx<'_> {
        Ctx {
            t_s: self.state.t_s,
            dt_s: h,
            alpha_rad: self.state.alpha_rad,
            alpha_dot_rad_s: self.state.alpha_dot_rad_s,
            handle_user_m: self.state.handle_user_m,
            handle_velocity_user_m_s: self.state.handle_velocity_user_m_s,
            blocked,
            last_joint_torque_nm: self.state.joint_torque_nm,
            params: &self.cfg.params,
        }
    }

    fn substep(&mut self, h: f64, currents_ma: &[f64; 4], handle: &HandleCondition) {
        let blocked = matches!(handle, HandleCondition::Blocked);
        let joint1_locked = matches!(handle, HandleCondition::Joint1Locked(_));
        if blocked {
            self.state.alpha_dot_rad_s = [0.0; 2];
        }
        if joint1_locked {
            self.state.alpha_dot_rad_s[0] = 0.0;
        }
        // Effects see a snapshot of the state; they are taken out of `self` while they run.
        let mut effects = std::mem::take(&mut self.effects);
        let ip = self.cfg.params.ip;
        let pn = self.cfg.pneumatics;

        // 1. converter set points (eq. 2.2 with its 0.1–5 bar output range)
        let mut p_set = [0.0; 4];
        for c in 0..4 {
            let i = if currents_ma[c].is_finite() {
                currents_ma[c]
            } else {
                ip.current_min_ma
            };
            p_set[c] = ip.pressure_bar(i);
        }
        {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.pressure_command(&ctx, &mut p_set);
            }
        }

        // 2. where the muscles are: angle seen through the cables, ε, ε̇, volume
        let mut alpha_muscle = self.state.alpha_rad;
        {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.transmission(&ctx, &mut alpha_muscle);
            }
        }
        let mut eps = [0.0; 4];
        let mut eps_rate = [0.0; 4];
        for c in 0..4 {
            let (j, m) = self.channel_owner[c];
            let jc = &self.model.joints[j];
            let e = jc.epsilons(alpha_muscle[j]);
            eps[c] = e[m];
            // ε1 = ε0 − (R/l0)α, ε2 = ε0 + (R/l0)α
            let sign = if m == 0 { -1.0 } else { 1.0 };
            eps_rate[c] = sign * jc.epsilon_per_rad * self.state.alpha_dot_rad_s[j];
        }

        // 3. converters and air (see `pneumatics`)
        let wn = ip.natural_freq_rad_s;
        let zeta = ip.damping_ratio;
        let mut flow = self.state.regulator_flow_bar_s;
        for c in 0..4 {
            let p = self.state.pressure_bar[c];
            flow[c] += h * (wn * wn * (p_set[c] - p) - 2.0 * zeta * wn * flow[c]);
        }
        {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.regulator_flow(&ctx, &mut flow);
            }
        }
        let mut pressure = self.state.pressure_bar;
        for c in 0..4 {
            let (j, _) = self.channel_owner[c];
            let (v, dv_deps) = self.volumes[j].at(eps[c]);
            let v_dot = dv_deps * eps_rate[c];
            let p = pressure[c];
            let p_dot = flow[c] * self.volume_ref_m3[c] / v
                - pn.polytropic_index * (p + pn.atmosphere_bar) * v_dot / v;
            pressure[c] = (p + h * p_dot).clamp(0.0, pn.supply_bar);
        }

        // 4. forces: pressure in the force law, polynomial (eq. 3.1), a cable cannot push
        let mut p_force = pressure;
        {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.muscle_pressure(&ctx, &mut p_force);
            }
        }
        let mut force = [0.0; 4];
        {
            let ctx = self.ctx(h, blocked);
            for c in 0..4 {
                let (j, _) = self.channel_owner[c];
                let mut f = (self.cfg.mechanics.muscle_force_ratio
                    * self.cfg.params.muscle.force_n(eps[c], p_force[c]))
                .max(0.0);
                let view = MuscleView {
                    channel: c,
                    joint: j,
                    epsilon: eps[c],
                    epsilon_rate_per_s: eps_rate[c],
                    pressure_bar: p_force[c],
                };
                for e in effects.all_mut() {
                    e.muscle_force(&ctx, &view, &mut f);
                }
                force[c] = f.max(0.0);
            }
        }
        // τ = R (F2 − F1) (eq. 3.2)
        let mut torque = [0.0; 2];
        for j in 0..2 {
            let map = self.cfg.params.joints[j].channel_of_muscle;
            let r = self.cfg.params.joints[j].pulley_radius_m;
            torque[j] = r * (force[(map[1] & 3) as usize] - force[(map[0] & 3) as usize])
                - self.parallel_torque_nm(j);
        }
        {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.joint_torque(&ctx, &mut torque);
            }
        }

        // 5. the handle and the arm
        let kin = &self.model.kinematics;
        let trig = kin.trig(self.state.alpha_rad);
        let jac = kin.jacobian_at(&trig);
        let mut env = HandleForces::default();
        if !blocked {
            let ctx = self.ctx(h, blocked);
            for e in effects.all_mut() {
                e.handle_force(&ctx, &mut env);
            }
        }
        self.effects = effects;

        let force_on_holder = if blocked {
            // statics: τ = Jᵀ f  ⇒  f = J⁻ᵀ τ
            match jac.transpose().inverse() {
                Some(jt_inv) => jt_inv.mul_vec(torque),
                None => [0.0; 2],
            }
        } else {
            let x = self.state.handle_user_m;
            let v = self.state.handle_velocity_user_m_s;
            let hand = match handle {
                HandleCondition::Hand(s) | HandleCondition::Joint1Locked(Some(s)) => [
                    s.stiffness_n_per_m * (s.target_user_m[0] - x[0])
                        + s.damping_n_s_per_m * (s.target_velocity_user_m_s[0] - v[0]),
                    s.stiffness_n_per_m * (s.target_user_m[1] - x[1])
                        + s.damping_n_s_per_m * (s.target_velocity_user_m_s[1] - v[1]),
                ],
                _ => [0.0; 2],
            };
            let (a, hs) = (env.arm_side_user_n, env.handle_side_user_n);
            let external = [hand[0] + hs[0] + a[0], hand[1] + hs[1] + a[1]];
            self.integrate_arm(h, &jac, torque, external, joint1_locked);
            // the load cell sits between the arm and the handle: it carries what acts beyond it
            [-(hand[0] + hs[0]), -(hand[1] + hs[1])]
        };

        self.state.pressure_bar = pressure;
        self.state.pressure_set_bar = p_set;
        self.state.regulator_flow_bar_s = flow;
        self.state.muscle_force_n = force;
        self.state.joint_torque_nm = torque;
        self.state.force_on_holder_user_n = force_on_holder;
        self.state.t_s += h;
        self.state.handle_user_m = self.model.kinematics.forward_user(self.state.alpha_rad);
        let jac_new = self.model.kinematics.jacobian(self.state.alpha_rad);
        self.state.handle_velocity_user_m_s = jac_new.mul_vec(self.state.alpha_dot_rad_s);
    }

    /// I(θ2) α̈ + C(θ, θ̇) = τ + Jᵀ F_ext − b α̇ + τ_stops (eq. 4.14–4.17), semi-implicit Euler.
    fn integrate_arm(
        &mut self,
        h: f64,
        jac: &Mat2<f64>,
        torque: Vec2<f64>,
        external_user_n: Vec2<f64>,
        joint1_locked: bool,
    ) {
        let p = &self.cfg.params;
        let mech = &self.cfg.mechanics;
        let theta = self.model.kinematics.theta(self.state.alpha_rad);
        let w = self.state.alpha_dot_rad_s;
        let inertia = joint_inertia(p, theta[1]);
        let coriolis = coriolis_torques(p, theta[1], w);
        let ext = jac.transpose().mul_vec(external_user_n);
        let mut rhs = [0.0; 2];
        for j in 0..2 {
            let a = self.state.alpha_rad[j];
            let lo = p.joints[j].alpha_min_rad - mech.hard_stop_margin_rad;
            let hi = p.joints[j].alpha_max_rad + mech.hard_stop_margin_rad;
            let stop = if a > hi {
                -mech.hard_stop_stiffness_nm_per_rad * (a - hi)
                    - mech.hard_stop_damping_nm_s_per_rad * w[j].max(0.0)
            } else if a < lo {
                mech.hard_stop_stiffness_nm_per_rad * (lo - a)
                    - mech.hard_stop_damping_nm_s_per_rad * w[j].min(0.0)
            } else {
                0.0
            };
            rhs[j] =
                torque[j] + ext[j] - coriolis[j] - mech.joint_damping_nm_s_per_rad[j] * w[j] + stop;
        }
        let acc = if joint1_locked {
            [0.0, rhs[1] / inertia.0[1][1]]
        } else {
            match inertia.inverse() {
                Some(inv) => inv.mul_vec(rhs),
                None => [0.0; 2],
            }
        };
        for j in 0..2 {
            self.state.alpha_dot_rad_s[j] += h * acc[j];
            if joint1_locked && j == 0 {
                self.state.alpha_dot_rad_s[0] = 0.0;
            }
            self.state.alpha_rad[j] += h * self.state.alpha_dot_rad_s[j];
        }
    }

    /// Reads the sensors at the present instant.
    fn sample(&mut self) -> Measurement {
        let s = &self.cfg.sensors;
        let lc = self.cfg.params.load_cell;
        let alpha = self.state.alpha_rad;
        let f_sensor = self
            .model
            .kinematics
            .user_to_sensor(alpha, self.state.force_on_holder_user_n);
        let mut raw = RawSensors {
            loadcell_v: [
                f_sensor[0] / lc.gain_n_per_v[0]
                    + lc.offset_v[0]
                    + s.loadcell_noise_n[0] * self.rng.normal() / lc.gain_n_per_v[0],
                f_sensor[1] / lc.gain_n_per_v[1]
                    + lc.offset_v[1]
                    + s.loadcell_noise_n[1] * self.rng.normal() / lc.gain_n_per_v[1],
            ],
            encoder_alpha_rad: alpha,
        };
        let mut effects = std::mem::take(&mut self.effects);
        {
            let ctx = self.ctx(0.0, false);
            for e in effects.all_mut() {
                e.sensor(&ctx, &mut raw);
            }
        }
        self.effects = effects;
        // ADC: clip to the span, quantize
        let mut volts = raw.loadcell_v;
        if s.adc_bits > 0 {
            let lsb = 2.0 * s.adc_span_v / (1u64 << s.adc_bits.min(52)) as f64;
            for v in volts.iter_mut() {
                *v = (v.clamp(-s.adc_span_v, s.adc_span_v) / lsb).round() * lsb;
            }
        }
        let mut counts = [0i64; 2];
        let mut alpha_meas = raw.encoder_alpha_rad;
        for j in 0..2 {
            let cpr = s.encoder_counts_per_rev[j];
            if cpr > 0 {
                let per_rad = cpr as f64 / std::f64::consts::TAU;
                counts[j] = (raw.encoder_alpha_rad[j] * per_rad).round() as i64;
                alpha_meas[j] = counts[j] as f64 / per_rad;
            } else {
                counts[j] = (raw.encoder_alpha_rad[j] * 1e9).round() as i64;
            }
        }
        let force_sensor_n = lc.forces_n(volts);
        let force_user_n =
            Kinematics::sensor_to_user_at(&self.model.kinematics.trig(alpha_meas), force_sensor_n);
        Measurement {
            t_s: self.state.t_s,
            encoder_counts: counts,
            loadcell_v: volts,
            alpha_rad: alpha_meas,
            force_sensor_n,
            force_user_n,
            pressure_bar: self.state.pressure_bar,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The identified rig's parallel element is a spring while it sticks and slips past its
    /// break-away: placed at a pose it exerts nothing (no preload toward neutral), deflected
    /// by half its reach it is a spring, deflected by three reaches it holds the break-away
    /// and has re-anchored.
    #[test]
    fn parallel_element_sticks_then_slips() {
        let mut cfg = TwinConfig::identified_rig();
        cfg.initial_alpha_rad = [0.2, -0.3];
        let k = cfg.mechanics.parallel_stiffness_nm_per_rad;
        let tb = cfg.mechanics.parallel_breakaway_nm;
        assert!(k[0] > 50.0 && k[1] > 10.0 && tb[0] > 1.0, "{k:?} {tb:?}");
        let mut twin = Twin::new(cfg);
        assert_eq!(twin.parallel_torque_nm(0), 0.0);
        let reach = tb[0] / k[0];
        twin.state.alpha_rad[0] = 0.2 + 0.5 * reach;
        assert!((twin.parallel_torque_nm(0) - 0.5 * tb[0]).abs() < 1e-9);
        twin.state.alpha_rad[0] = 0.2 + 3.0 * reach;
        assert!((twin.parallel_torque_nm(0) - tb[0]).abs() < 1e-9);
        // back by one reach from there: the spring now rests 2 reaches out
        twin.state.alpha_rad[0] = 0.2 + 2.0 * reach;
        assert!(twin.parallel_torque_nm(0).abs() < 1e-9);
        // the default twin has none
        let mut plain = Twin::new(TwinConfig::thesis());
        plain.state.alpha_rad = [0.3, 0.3];
        assert_eq!(plain.parallel_torque_nm(0), 0.0);
    }
}
