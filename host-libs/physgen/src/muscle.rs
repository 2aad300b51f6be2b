//! The muscles as gas volumes behind their pressure regulators.
//!
//! - Force: Tondu & Lopez, "Modeling and control of McKibben artificial muscle robot
//!   actuators", IEEE Control Systems 20(2), 2000: F = π r0² P [a (1 − k ε)² − b],
//!   a = 3 / tan² β0, b = 1 / sin² β0 (β0 the braid angle at rest, k the correction for the
//!   end caps). A cable cannot push: where the formula goes negative the cable is slack.
//! - Volume: the braid's geometry (Chou & Hannaford, "Measurement and modeling of McKibben
//!   pneumatic artificial muscles", IEEE T-RA 12(1), 1996): L = b cos β, so
//!   cos β = (1 − ε) cos β0 and V ∝ sin² β cos β.
//! - Gas: isothermal filling, d(P V)/dt = (V0 / τ_fill)·(p_reg − p) with P the absolute
//!   pressure: Ṗ = ((V0 / τ_fill)(p_reg − p) − P V̇) / V. A contraction at constant regulator
//!   pressure changes the pressure until the regulator refills: the compressibility the
//!   loop's pneumatic term describes, here from the gas law.
//! - Regulator: each I/P converter is a second-order pressure servo (ωn, ζ) behind a dead
//!   time, its set-point from the current (eq. 2.2) with a per-channel gain and offset.

/// Atmospheric pressure, bar (gauge → absolute).
pub const ATM_BAR: f64 = 1.013;

/// One muscle type (Festo fluidic muscle of the rig, §2.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Muscle {
    pub r0_m: f64,
    pub braid_angle_rad: f64,
    pub k: f64,
    pub rest_length_m: f64,
}

impl Muscle {
    /// A 20 mm Festo muscle: inner radius ≈ 9.5 mm, braid angle 22°, end-cap factor 1.25
    /// (Tondu & Lopez's fits of similar muscles give k ≈ 1.0–1.5).
    pub fn festo_20(rest_length_m: f64) -> Self {
        Muscle {
            r0_m: 0.0095,
            braid_angle_rad: 22f64.to_radians(),
            k: 1.25,
            rest_length_m,
        }
    }

    /// Tondu–Lopez force (N) at contraction ε and gauge pressure `p_bar`; ≥ 0 (slack cable).
    pub fn force_n(&self, epsilon: f64, p_bar: f64) -> f64 {
        let t = self.braid_angle_rad.tan();
        let s = self.braid_angle_rad.sin();
        let a = 3.0 / (t * t);
        let b = 1.0 / (s * s);
        let u = 1.0 - self.k * epsilon;
        let f =
            std::f64::consts::PI * self.r0_m * self.r0_m * p_bar.max(0.0) * 1e5 * (a * u * u - b);
        f.max(0.0)
    }

    /// Volume at rest (m³).
    pub fn rest_volume_m3(&self) -> f64 {
        std::f64::consts::PI * self.r0_m * self.r0_m * self.rest_length_m
    }

    /// Volume and dV/dε at contraction ε.
    pub fn volume_m3(&self, epsilon: f64) -> (f64, f64) {
        let c0 = self.braid_angle_rad.cos();
        let g = |c: f64| (1.0 - c * c) * c;
        let c = ((1.0 - epsilon) * c0).clamp(0.05, 0.999);
        let scale = self.rest_volume_m3() / g(c0);
        (scale * g(c), scale * (-c0) * (1.0 - 3.0 * c * c))
    }
}

/// One I/P converter and the tube to its muscle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Regulator {
    /// Set-point = gain·I + offset (eq. 2.2 with this channel's spread).
    pub gain_bar_per_ma: f64,
    pub offset_bar: f64,
    pub omega_n_rad_s: f64,
    pub zeta: f64,
    /// Dead time of the converter and tube, whole simulation steps.
    pub dead_steps: usize,
    /// Time constant of filling the muscle's volume through the tube.
    pub fill_s: f64,
    /// Highest deliverable pressure (the supply less the valve's drop), bar.
    pub cap_bar: f64,
    /// Largest rise and fall of the muscle's pressure the valve's flow allows, bar/s
    /// (infinite: the flow is never choked).
    pub max_rise_bar_s: f64,
    pub max_fall_bar_s: f64,
}

impl Regulator {
    /// The set-point for a current, within the converter's range (0.1–5 bar, §2.1).
    pub fn setpoint_bar(&self, current_ma: f64) -> f64 {
        (self.gain_bar_per_ma * current_ma + self.offset_bar).clamp(0.1, 5.0)
    }

    /// (ẋ, ẍ) of the pressure servo's state (x, ẋ) driven by the delayed set-point.
    pub fn servo_rate(&self, x: f64, xd: f64, setpoint_bar: f64) -> (f64, f64) {
        let w = self.omega_n_rad_s;
        (xd, w * w * (setpoint_bar - x) - 2.0 * self.zeta * w * xd)
    }

    /// ṗ of the muscle (gauge bar/s): the isothermal fill from the servo's output `x`.
    pub fn fill_rate(&self, m: &Muscle, p_bar: f64, x: f64, epsilon: f64, epsilon_dot: f64) -> f64 {
        let (v, dv) = m.volume_m3(epsilon);
        let v0 = m.rest_volume_m3();
        let target = x.clamp(0.0, self.cap_bar);
        let flow = (v0 / self.fill_s * (target - p_bar))
            .clamp(-v0 * self.max_fall_bar_s, v0 * self.max_rise_bar_s);
        (flow - (p_bar + ATM_BAR) * dv * epsilon_dot) / v
    }
}
