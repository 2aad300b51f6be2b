//! Impedance mode: a Cartesian virtual spring-damper-mass about a target point,
//! rendered by the closed force loop. The force the robot should exert on the handle is
//! F = K (x₀ − x) − B ẋ − M ẍ (user frame, diagonal K, B, M), and
//! [`crate::ForceLoop::step_direct`] makes the load cell read it. K = 0 with a small B is the
//! transparent mode: the loop then cancels the muscles' own stiffness, which open loop cannot
//! go below (K_min). How the rendering is made faithful (a motion observer, the spring led by
//! the loop's residual lag, the arm's inertia fed forward) is in docs/impedance.md.

use crate::force_loop::ForceLoopConfig;
use crate::guard::sign_beyond;
use pam_model::kinematics::PoseTrig;
use pam_model::{Mat2, RobotModel, Vec2};

/// Largest virtual stiffness a request may carry, N/m (above 1.5 × the open loop's K_max).
pub const MAX_IMPEDANCE_STIFFNESS_N_PER_M: f32 = 5000.0;
/// Largest virtual damping a request may carry, N·s/m.
pub const MAX_IMPEDANCE_DAMPING_N_S_PER_M: f32 = 300.0;
/// Largest virtual mass the controller accepts, kg. Negative masses (less inertia than the
/// arm's) are refused: they are the unstable direction of impedance rendering; 2 kg already
/// made the loop ring on a firm grip on the twin (the guard tripped). The mass is
/// not on the wire (not rendered faithfully: docs/impedance.md, "Virtual mass"); the twin's
/// impedance trial can ask for it.
pub const MAX_IMPEDANCE_MASS_KG: f32 = 1.0;
/// Largest distance of the target from the neutral handle, m (the workspace's scale).
pub const MAX_IMPEDANCE_TARGET_M: f32 = 0.3;

/// Bandwidth of the first-order filter of the handle velocity that the damping acts on, and
/// that the speed guards read, rad/s (encoder steps differentiated at 1 kHz are noise; the
/// operator moves below 2 Hz). Its roll-off above the operator's band keeps the damping out of
/// the ≈ 9 Hz resonance of the arm's mass on a firm grip: on the observer's velocity (no
/// roll-off there) B = 20 N·s/m at K = 653 N/m made the loop ring at that resonance.
const VELOCITY_FILTER_RAD_S: f32 = 60.0;

/// Bandwidth of the handle-motion observer, rad/s: its three poles sit at 1/(1 + ω·dt)
/// ≈ e^(−ω·dt). Its velocity lags 0.2–4.5 ms in the operator's band (the filter above:
/// 17 ms), its acceleration feeds the arm's inertia and the virtual mass.
pub const MOTION_OBSERVER_RAD_S: f32 = 60.0;

/// Lag of the closed force loop at the operator's frequencies that the spring term is led by,
/// s: a spring force rendered T late is K (x₀ − x) + K T ẋ, a negative damping K T that eats
/// the commanded B. With the arm's inertia fed forward and the integral at
/// [`IMPEDANCE_INTEGRAL_SCALE`], the loop renders the force 10 ms late at the operator's
/// frequencies (measured on the twin: docs/impedance.md; 20 ms with the designed integral
/// and no inertia feed-forward).
pub const IMPEDANCE_LEAD_S: f32 = 0.010;

/// The force loop's integral gain in impedance mode, × the design's: what the loop leaves of
/// the arm's motion-induced forces (the muscles' compressibility, the inertia the model
/// misses) is rendered as a damping error that differs between the axes (X −2, Y +1 N·s/m);
/// ×1.5 halves the difference. ×2 rings at B = 20 N·s/m, K = 653 N/m on a firm grip.
pub const IMPEDANCE_INTEGRAL_SCALE: f32 = 1.5;

/// A released handle: the spring asks for at least this force (norm), N…
pub const RELEASE_FORCE_MIN_N: f32 = 3.0;
/// …the load cell reads less than this fraction of it…
pub const RELEASE_FORCE_RATIO: f32 = 0.25;
/// …while the handle moves faster than this (m/s)…
pub const RELEASE_SPEED_M_S: f32 = 0.05;
/// …for this long (s). A held handle pushes back: the load cell reads the spring's force
/// within the loop's lag while the hand keeps the handle nearly still; a released one reads
/// nearly nothing while the loop accelerates the arm.
pub const RELEASE_TIME_S: f32 = 0.015;

/// The ringing detector's band on the handle's filtered speed, per axis, m/s: a 4.5 Hz swing
/// of 0.7 mm, ±0.7 N on a relaxed hand's spring (the encoders' count, ≈ 0.3 mm at the
/// handle, differentiated gives spikes of 17 mm/s that die within 17 ms).
pub const RINGING_SPEED_M_S: f32 = 0.02;
/// Shortest and longest time between two reversals across the band that count as ringing, s:
/// half a period at 7 Hz and at 3.3 Hz. The arm's mass on a relaxed hand (1000 N/m) rings at
/// 4–5 Hz; an operator reverses the handle below 2 Hz (a quarter second or more apart), a
/// handle that sticks and slips on the table does not reverse, and a firm grip (5000 N/m) puts
/// the arm's mass at ≈ 9 Hz, which the design's gains damp.
pub const RINGING_HALF_PERIOD_S: [f32; 2] = [0.07, 0.15];
/// Reversals in the leaky count (time constant 1 s) beyond which the handle rings: three, a
/// period and a half of it (the force loop's guard trips at six swings of its error beyond
/// ±2 N). Two reversals also count the quick turns of an operator's path (the twin's
/// scripted operator, 0.1–2 Hz, turned the gains down within 8–24 s of its trials).
pub const RINGING_FLIPS: f32 = 2.5;

/// A handle that rings: its filtered velocity reverses across ±[`RINGING_SPEED_M_S`] within
/// [`RINGING_HALF_PERIOD_S`] of the previous reversal, per axis, in a leaky count (time
/// constant 1 s); once the count passes [`RINGING_FLIPS`] the handle has rung, until reset.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ringing {
    sign: [i8; 2],
    since_flip_s: Vec2<f32>,
    flips: Vec2<f32>,
    rang: bool,
}

impl Ringing {
    const fn new() -> Self {
        Ringing {
            sign: [0; 2],
            since_flip_s: [0.0; 2],
            flips: [0.0; 2],
            rang: false,
        }
    }

    fn update(&mut self, v_m_s: Vec2<f32>, dt_s: f32) {
        let [short_s, long_s] = RINGING_HALF_PERIOD_S;
        for a in 0..2 {
            self.flips[a] *= 1.0 - dt_s;
            self.since_flip_s[a] += dt_s;
            let last = self.sign[a];
            let s = sign_beyond(v_m_s[a], RINGING_SPEED_M_S, last);
            if s != last {
                let t = self.since_flip_s[a];
                if last != 0 && t >= short_s && t <= long_s {
                    self.flips[a] += 1.0;
                }
                self.since_flip_s[a] = 0.0;
            }
            self.sign[a] = s;
            self.rang |= self.flips[a] > RINGING_FLIPS;
        }
    }
}

/// The handle's motion estimated from the encoders, and the released-handle detector's timer.
///
/// Two estimates: a first-order filtered difference ([`Impedance::velocity_m_s`], 17 ms of
/// lag, rolled off above the operator's band: the damping and the speed guards use it), and a
/// critically damped tracking observer of a constant-acceleration model (a fading-memory g-h-k
/// filter) that has no steady lag on a ramp or a parabola
/// ([`Impedance::observed_velocity_m_s`], [`Impedance::acceleration_m_s2`]: the spring's lead,
/// the inertia and the virtual mass use it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impedance {
    fresh: bool,
    last_x_m: Vec2<f32>,
    v_m_s: Vec2<f32>,
    obs_x_m: Vec2<f32>,
    obs_v_m_s: Vec2<f32>,
    obs_a_m_s2: Vec2<f32>,
    released_s: f32,
    ringing: Ringing,
}

impl Default for Impedance {
    fn default() -> Self {
        Self::new()
    }
}

impl Impedance {
    pub const fn new() -> Self {
        Impedance {
            fresh: true,
            last_x_m: [0.0; 2],
            v_m_s: [0.0; 2],
            obs_x_m: [0.0; 2],
            obs_v_m_s: [0.0; 2],
            obs_a_m_s2: [0.0; 2],
            released_s: 0.0,
            ringing: Ringing::new(),
        }
    }

    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Filtered velocity, m/s.
    pub fn velocity_m_s(&self) -> Vec2<f32> {
        self.v_m_s
    }

    /// Whether the handle has rung at 3.3–7 Hz since the reset ([`RINGING_SPEED_M_S`]): the
    /// arm's mass on a relaxed hand, which the impedance mode then stops feeding.
    pub fn rang(&self) -> bool {
        self.ringing.rang
    }

    /// The observer's velocity, m/s.
    pub fn observed_velocity_m_s(&self) -> Vec2<f32> {
        self.obs_v_m_s
    }

    /// The observer's acceleration, m/s².
    pub fn acceleration_m_s2(&self) -> Vec2<f32> {
        self.obs_a_m_s2
    }

    /// The released-handle detector, once per period after [`Impedance::track`]: true once
    /// the loop has asked for at least [`RELEASE_FORCE_MIN_N`] while the load cell read
    /// less than [`RELEASE_FORCE_RATIO`] of it and the handle moved faster than
    /// [`RELEASE_SPEED_M_S`], for [`RELEASE_TIME_S`] in a row.
    pub fn released(&mut self, target_n: Vec2<f32>, measured_n: Vec2<f32>, dt_s: f32) -> bool {
        let t2 = target_n[0] * target_n[0] + target_n[1] * target_n[1];
        let m2 = measured_n[0] * measured_n[0] + measured_n[1] * measured_n[1];
        let v2 = self.v_m_s[0] * self.v_m_s[0] + self.v_m_s[1] * self.v_m_s[1];
        let r2 = RELEASE_FORCE_RATIO * RELEASE_FORCE_RATIO;
        if t2 > RELEASE_FORCE_MIN_N * RELEASE_FORCE_MIN_N
            && m2 < r2 * t2
            && v2 > RELEASE_SPEED_M_S * RELEASE_SPEED_M_S
        {
            self.released_s += dt_s;
        } else {
            self.released_s = 0.0;
        }
        self.released_s >= RELEASE_TIME_S
    }

    /// Updates both motion estimates from the handle position `x_m` (any fixed origin);
    /// returns the filtered velocity, m/s.
    pub fn track(&mut self, x_m: Vec2<f32>, dt_s: f32) -> Vec2<f32> {
        if self.fresh {
            self.last_x_m = x_m;
            self.obs_x_m = x_m;
            self.fresh = false;
        }
        let wdt = VELOCITY_FILTER_RAD_S * dt_s;
        let alpha = wdt / (1.0 + wdt);
        // three poles at θ = 1/(1 + ω·dt): the fading-memory gains
        let th = 1.0 / (1.0 + MOTION_OBSERVER_RAD_S * dt_s);
        let one = 1.0 - th;
        let g = 1.0 - th * th * th;
        let h = 1.5 * one * one * (1.0 + th) / dt_s;
        let k = one * one * one / (dt_s * dt_s);
        for a in 0..2 {
            let raw = (x_m[a] - self.last_x_m[a]) / dt_s;
            self.v_m_s[a] += alpha * (raw - self.v_m_s[a]);
            let xp = self.obs_x_m[a] + (self.obs_v_m_s[a] + 0.5 * self.obs_a_m_s2[a] * dt_s) * dt_s;
            let e = x_m[a] - xp;
            self.obs_x_m[a] = xp + g * e;
            self.obs_v_m_s[a] += self.obs_a_m_s2[a] * dt_s + h * e;
            self.obs_a_m_s2[a] += k * e;
        }
        self.last_x_m = x_m;
        self.ringing.update(self.v_m_s, dt_s);
        self.v_m_s
    }
}

/// The virtual impedance, diagonal in the user frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VirtualImpedance {
    pub stiffness_n_per_m: Vec2<f32>,
    pub damping_n_s_per_m: Vec2<f32>,
    pub mass_kg: Vec2<f32>,
}

/// F = K (x₀ − x − T ẋ_obs) − B ẋ − M ẍ per axis, N, with T = [`IMPEDANCE_LEAD_S`]: the
/// spring-damper-mass rendered through a loop that lags by T (ẋ the filtered velocity, ẋ_obs
/// and ẍ the observer's).
pub fn impedance_force_n(
    target_m: Vec2<f32>,
    imp: &VirtualImpedance,
    motion: &Impedance,
    x_m: Vec2<f32>,
) -> Vec2<f32> {
    let mut f = [0.0; 2];
    for a in 0..2 {
        let lead_m = IMPEDANCE_LEAD_S * motion.obs_v_m_s[a];
        f[a] = imp.stiffness_n_per_m[a] * (target_m[a] - x_m[a] - lead_m)
            - imp.damping_n_s_per_m[a] * motion.v_m_s[a]
            - imp.mass_kg[a] * motion.obs_a_m_s2[a];
    }
    f
}

/// The spring-damper force `f_ref` scaled to what may be asked and what the muscles can give
/// at the pose, its direction kept, and the scale (1: neither applies).
/// - What may be asked: each axis within `max_force_n` (the supervisor's bound on a force
///   request, `SafetyConfig::max_request_force_n`): a stiff spring far from its target would
///   otherwise ask for up to 5000 N/m × 0.3 m.
/// - What the muscles can give: the loop's steady command is the force plus
///   `[integral, inertia]` (the impedance mode has no gain plane and no measured gain), and
///   its inverse model runs at the least stiffness, so the range is the capability
///   quadrilateral's torque range ([`RobotModel::reachable_force_scale_least_stiffness`],
///   `reach_margin` of it). Clamped joint by joint instead, the force would turn away from
///   the target, and the loop's guard would vent on the error it cannot close.
pub fn reachable_impedance_force_n(
    model: &RobotModel<f32>,
    cfg: &ForceLoopConfig,
    (alpha_rad, trig): (Vec2<f32>, &PoseTrig<f32>),
    (f_ref, max_force_n): (Vec2<f32>, f32),
    [integral, inertia]: [Vec2<f32>; 2],
) -> (Vec2<f32>, f32) {
    let largest = f_ref[0].abs().max(f_ref[1].abs());
    let bound = if largest > max_force_n {
        max_force_n / largest
    } else {
        1.0
    };
    let f = [bound * f_ref[0], bound * f_ref[1]];
    let offset = [integral[0] + inertia[0], integral[1] + inertia[1]];
    let margin = cfg.reach_margin;
    let s = model.reachable_force_scale_least_stiffness(alpha_rad, trig, f, offset, margin);
    ([s * f[0], s * f[1]], s * bound)
}

/// The force the muscles need beyond the handle's so that the arm's own inertia does not
/// reach the load cell: M_C(α) ẍ, N (the Cartesian mass of eq. 4.11 at the pose, from the
/// pose's sines and cosines; zero at a singular pose).
pub fn arm_inertia_force_n(
    model: &RobotModel<f32>,
    trig: &PoseTrig<f32>,
    acc_m_s2: Vec2<f32>,
) -> Vec2<f32> {
    // cos θ2 = cos((θ1 + θ2) − θ1), from the sines and cosines already computed
    let cos_theta2 = trig.c12 * trig.c1 + trig.s12 * trig.s1;
    let inertia = pam_model::cartesian::joint_inertia_cos(&model.params, cos_theta2);
    let jac = model.kinematics.jacobian_at(trig);
    match pam_model::cartesian::joint_to_cartesian(&jac, &inertia) {
        Some(Mat2(m)) => [
            m[0][0] * acc_m_s2[0] + m[0][1] * acc_m_s2[1],
            m[1][0] * acc_m_s2[0] + m[1][1] * acc_m_s2[1],
        ],
        None => [0.0; 2],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spring force beyond the request bound is cut to it per axis, beyond the muscles to
    /// what they give; the direction is kept either way, and a force within both is left as
    /// it is.
    #[test]
    fn a_spring_force_is_bounded_in_its_direction() {
        let model = RobotModel::<f32>::thesis();
        let cfg = ForceLoopConfig::designed();
        let alpha = [0.1, -0.2];
        let trig = model.kinematics.trig(alpha);
        let none = [[0.0; 2]; 2];
        let scaled = |f: Vec2<f32>, max: f32| {
            reachable_impedance_force_n(&model, &cfg, (alpha, &trig), (f, max), none)
        };
        let (f, s) = scaled([6.0, -5.0], 100.0);
        assert_eq!((f, s), ([6.0, -5.0], 1.0));
        // the bound: 40 N on the larger axis
        let (f, s) = scaled([60.0, -30.0], 40.0);
        assert!(
            (f[0] - 40.0).abs() < 1e-4 && (f[1] + 20.0).abs() < 1e-4,
            "{f:?} {s}"
        );
        // the muscles: far beyond them, the direction kept
        let (f, s) = scaled([600.0, -660.0], 1e4);
        assert!(s < 0.5 && s > 0.0, "{f:?} {s}");
        assert!((f[1] / f[0] + 1.1).abs() < 1e-4, "{f:?}");
    }

    /// Released: asked for 9 N, reading 0.5 N, moving at 0.1 m/s, for 15 ms: yes. Held (the
    /// load cell reads the force), still, or asked for little: never.
    #[test]
    fn a_released_handle_is_one_that_reads_nothing_while_it_runs() {
        let dt = 0.001;
        let moving = |imp: &mut Impedance| {
            imp.reset();
            imp.track([0.0; 2], dt);
            imp.track([0.0001, 0.0], dt);
            for i in 2..200 {
                imp.track([0.0001 * i as f32, 0.0], dt);
            }
        };
        let mut imp = Impedance::new();
        moving(&mut imp);
        assert!(imp.velocity_m_s()[0] > 0.09);
        let runs = |imp: &mut Impedance, target: Vec2<f32>, measured: Vec2<f32>| {
            (0..30).position(|_| imp.released(target, measured, dt))
        };
        assert_eq!(runs(&mut imp, [9.0, 0.0], [0.5, 0.0]), Some(14));
        moving(&mut imp);
        assert_eq!(runs(&mut imp, [9.0, 0.0], [6.0, 0.0]), None, "held");
        moving(&mut imp);
        assert_eq!(runs(&mut imp, [2.0, 0.0], [0.0, 0.0]), None, "little asked");
        imp.reset();
        for _ in 0..200 {
            imp.track([0.01, 0.0], dt);
        }
        assert_eq!(runs(&mut imp, [9.0, 0.0], [0.0, 0.0]), None, "still");
    }

    /// Periods until the handle swinging by `amp_m` at `hz` along X has rung, within 3 s.
    fn rings_after(amp_m: f32, hz: f32) -> Option<usize> {
        let mut imp = Impedance::new();
        let dt = 0.001;
        (0..3000).position(|k| {
            let t = k as f32 * dt;
            imp.track(
                [amp_m * (2.0 * core::f32::consts::PI * hz * t).sin(), 0.0],
                dt,
            );
            imp.rang()
        })
    }

    /// The arm's mass ringing on a relaxed hand (4–6 Hz, 1.5 mm) is seen within two periods;
    /// a swing below the speed band, the operator's pace (2 Hz) and a firm grip's 9 Hz never.
    #[test]
    fn a_handle_rings_at_a_relaxed_hands_frequency_only() {
        for hz in [4.0, 4.5, 6.0] {
            let k = rings_after(0.0015, hz).expect("rings");
            assert!((k as f32) < 2.0 * 1000.0 / hz, "{hz} Hz: after {k} periods");
        }
        assert_eq!(rings_after(0.0005, 4.5), None, "below the band");
        assert_eq!(rings_after(0.01, 2.0), None, "the operator's pace");
        assert_eq!(rings_after(0.0015, 9.0), None, "a firm grip's ringing");
    }

    /// The observer follows a parabola without lag (velocity and acceleration exact once
    /// settled), where the filtered difference lags by its time constant.
    #[test]
    fn the_motion_observer_tracks_a_parabola_without_lag() {
        let dt = 0.001;
        let mut imp = Impedance::new();
        let (v0, acc) = (0.05f32, 0.8f32);
        for i in 0..1000 {
            let t = i as f32 * dt;
            imp.track([v0 * t + 0.5 * acc * t * t, -v0 * t], dt);
        }
        let t = 0.999f32;
        let v = imp.observed_velocity_m_s();
        let a = imp.acceleration_m_s2();
        assert!((v[0] - (v0 + acc * t)).abs() < 1e-3, "{v:?}");
        assert!((v[1] + v0).abs() < 1e-3, "{v:?}");
        assert!((a[0] - acc).abs() < 0.05 && a[1].abs() < 0.05, "{a:?}");
        let lag_s = (v0 + acc * t - imp.velocity_m_s()[0]) / acc;
        assert!(
            (lag_s - 1.0 / VELOCITY_FILTER_RAD_S).abs() < 2e-3,
            "{lag_s}"
        );
    }

    /// At rest the spring alone; moving, the damping on the filtered velocity, the lead's K·T
    /// on the observer's, and the mass on its acceleration.
    #[test]
    fn the_impedance_force() {
        let imp = VirtualImpedance {
            stiffness_n_per_m: [300.0, 0.0],
            damping_n_s_per_m: [5.0, 5.0],
            mass_kg: [0.0, 2.0],
        };
        let mut still = Impedance::new();
        still.track([0.0; 2], 0.001);
        let f = impedance_force_n([0.02, 0.0], &imp, &still, [0.0; 2]);
        assert!((f[0] - 6.0).abs() < 1e-5 && f[1] == 0.0, "{f:?}");
        let moving = Impedance {
            fresh: false,
            last_x_m: [0.0; 2],
            v_m_s: [0.1, 0.1],
            obs_x_m: [0.0; 2],
            obs_v_m_s: [0.2, 0.2],
            obs_a_m_s2: [1.0, 1.0],
            released_s: 0.0,
            ringing: Ringing::new(),
        };
        let f = impedance_force_n([0.0; 2], &imp, &moving, [0.0; 2]);
        let want_x = -300.0 * IMPEDANCE_LEAD_S * 0.2 - 5.0 * 0.1;
        assert!((f[0] - want_x).abs() < 1e-5, "{f:?}");
        assert!((f[1] + 0.5 + 2.0).abs() < 1e-5, "{f:?}");
    }

    /// The arm's inertia at the handle: the model's Cartesian mass times the acceleration.
    #[test]
    fn the_arm_inertia_is_the_models_cartesian_mass() {
        let model = RobotModel::<f32>::thesis();
        let alpha = [0.1, -0.2];
        let trig = model.kinematics.trig(alpha);
        let m = model.cartesian_mass(alpha).unwrap();
        let f = arm_inertia_force_n(&model, &trig, [1.0, 0.5]);
        for r in 0..2 {
            let want = m.0[r][0] + 0.5 * m.0[r][1];
            assert!(
                (f[r] - want).abs() < 1e-4 * want.abs().max(1.0),
                "{f:?} {m:?}"
            );
        }
        assert!(
            m.0[0][0] > 0.1,
            "a mass of a few hundred grams at least: {m:?}"
        );
    }
}
